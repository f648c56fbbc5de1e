"""The ``cache`` subcommand: ``railfem cache info`` and ``railfem cache clear``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def cache_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", choices=("info", "clear"),
                   help="info: folder, number of kernels, total size and cap; clear: remove "
                        "every cached kernel")
    p.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                   help="folder of the kernel cache (default $RAILFEM_CACHE or "
                        "~/.cache/railfem)")


def cache_run(args) -> int:
    from ..jobs.cache import cache_info, clear_cache

    if args.action == "clear":
        r = clear_cache(args.cache_dir)
        sys.stdout.write(f"kernel cache {r['directory']}: removed {r['removed']} "
                         f"entries, {r['bytes'] / 1e6:.1f} MB\n")
        return 0
    r = cache_info(args.cache_dir)
    sys.stdout.write(f"kernel cache {r['directory']}: {r['entries']} entries, "
                     f"{r['bytes'] / 1e6:.1f} MB (cap {r['max_bytes'] / 1e6:g} MB, "
                     f"${r['size_variable']})\n")
    return 0
