"""The on-disk kernel cache stays under its size cap (least recently used files go first),
and ``railfem cache info`` / ``railfem cache clear`` show and empty it."""
import os

import numpy as np
import pytest

from railfem import cli
from railfem.track import kernelcache

KB = 1000


def kernel(n_bytes):
    """A kernel whose .npz file is a little over n_bytes."""
    return {"a": np.zeros(n_bytes // 8)}


def kernel_files(folder):
    return sorted(p.name for p in folder.glob("*.npz"))


def age(folder, key, seconds_ago):
    """Pretend the kernel file of ``key`` was last used ``seconds_ago``."""
    path = folder / f"{key}.npz"
    t = path.stat().st_mtime - seconds_ago
    os.utime(path, (t, t))


def test_store_keeps_the_folder_under_its_cap_dropping_least_recently_used(tmp_path):
    """The cache grew without limit (1.4 GB seen). Ten kernels of 100 kB in a 450 kB cap:
    the oldest go, the newest stay; a kernel read recently counts as new."""
    store = kernelcache.KernelStore(directory=tmp_path, max_items=1, max_bytes=450 * KB)
    keys = [kernelcache.content_key("test", i) for i in range(10)]
    for i, key in enumerate(keys[:4]):
        store.put(key, kernel(100 * KB))
        age(tmp_path, key, 1000 - 10 * i)  # key 0 oldest
    assert len(kernel_files(tmp_path)) == 4
    # reading key 0 from disk (not in memory: max_items=1) makes it the most recent
    assert store.get(keys[0]) is not None
    store.put(keys[4], kernel(100 * KB))  # 5 x 100 kB > 450 kB: the least recent goes
    left = kernel_files(tmp_path)
    assert f"{keys[1]}.npz" not in left
    assert {f"{k}.npz" for k in (keys[0], keys[2], keys[3], keys[4])} <= set(left)
    for key in keys[5:]:
        store.put(key, kernel(100 * KB))
    total = sum(p.stat().st_size for p in tmp_path.glob("*.npz"))
    assert total <= 450 * KB
    assert f"{keys[-1]}.npz" in kernel_files(tmp_path)  # the newest is always kept
    assert len(kernel_files(tmp_path)) == 4


def test_cap_from_the_environment_and_files_of_others_left_alone(tmp_path, monkeypatch):
    monkeypatch.setenv(kernelcache.SIZE_VARIABLE, "0.25")  # MB
    assert kernelcache.max_bytes() == 250 * KB
    other = tmp_path / "results.npz"  # not a kernel: a cache folder given by the user
    other.write_bytes(b"x" * 400 * KB)
    store = kernelcache.KernelStore(directory=tmp_path)
    for i in range(4):
        store.put(kernelcache.content_key("test", i), kernel(100 * KB))
    assert other.exists()
    assert len(kernel_files(tmp_path)) == 1 + 2  # results.npz and the two newest kernels
    monkeypatch.setenv(kernelcache.SIZE_VARIABLE, "lots")
    with pytest.raises(ValueError, match=f"{kernelcache.SIZE_VARIABLE}=.*MB"):
        kernelcache.max_bytes()


def test_cache_info_and_clear_commands(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "kernels"
    monkeypatch.setenv("RAILFEM_CACHE", str(folder))
    monkeypatch.setenv(kernelcache.SIZE_VARIABLE, "3")
    store = kernelcache.KernelStore()
    for i in range(3):
        store.put(kernelcache.content_key("test", i), kernel(100 * KB))
    (folder / "notes.txt").write_text("mine")
    assert cli.main(["cache", "info"]) == 0
    out = capsys.readouterr().out
    assert str(folder) in out and "3 entries" in out and "0.3 MB" in out and "3 MB" in out
    assert cli.main(["cache", "clear"]) == 0
    out = capsys.readouterr().out
    assert "removed 3" in out
    assert kernel_files(folder) == [] and (folder / "notes.txt").exists()
    # --cache-dir names another folder; an absent folder is an empty cache
    assert cli.main(["cache", "info", "--cache-dir", str(tmp_path / "none")]) == 0
    assert "0 entries" in capsys.readouterr().out
    assert not (tmp_path / "none").exists()
