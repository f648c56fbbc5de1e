"""Tests for railfem.plotting (matplotlib figures)."""

import os

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from railfem import plotting  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def non_blank(path):
    import matplotlib.image as mpimg

    image = mpimg.imread(str(path))[..., :3]
    background = image[0, 0]
    differs = np.any(np.abs(image - background) > 1e-3, axis=-1)
    return image.std() > 0 and differs.mean() > 0.01


def save_and_check(ax, tmp_path, name):
    path = plotting.save_figure(ax.figure, tmp_path / name)
    assert path == tmp_path / name and path.exists()
    assert non_blank(path)
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".")]  # no temp left
    return path


def synthetic_dispersion():
    """Two propagating types, one evanescent wave, one NaN column entry."""
    f = np.linspace(10, 3000, 40)
    omega = 2 * np.pi * f
    k_bend = np.sqrt(omega) * 0.6 * (1 - 0.01j)       # bending-like, lightly damped
    k_long = omega / 5000 * (1 - 0.005j)              # longitudinal
    k_near = (0.3 - 1j) * np.sqrt(omega) * 0.6        # evanescent (|Im k| > 3 Re k)
    k = np.column_stack([k_bend, k_long, k_near, k_bend * 1.5])
    k[:5, 3] = np.nan                                 # wave not cut on yet
    labels = np.array(["vertical bending", "longitudinal", "near field", "vertical bending"])
    return f, k, labels


def test_plot_dispersion_one_collection_per_type(tmp_path):
    f, k, labels = synthetic_dispersion()
    ax = plotting.plot_dispersion(f, k, np.broadcast_to(labels, k.shape))
    assert len(ax.collections) == 2  # the near field is not propagating
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert sorted(legend) == ["longitudinal", "vertical bending"]
    offsets = np.vstack([c.get_offsets() for c in ax.collections])
    assert len(offsets) == 40 + 40 + 35
    assert np.all(offsets[:, 0] > 0)
    save_and_check(ax, tmp_path, "dispersion.png")


def test_plot_dispersion_column_labels_none_and_threshold():
    f, k, labels = synthetic_dispersion()
    ax = plotting.plot_dispersion(f, k, labels)  # (nw,) labels broadcast
    assert len(ax.collections) == 2
    ax = plotting.plot_dispersion(f, k)
    assert len(ax.collections) == 1 and ax.get_legend() is None
    ax = plotting.plot_dispersion(f, k, max_attenuation=5.0)  # near field too
    assert len(ax.collections[0].get_offsets()) == 40 * 3 + 35
    with pytest.raises(ValueError, match="labels must have shape"):
        plotting.plot_dispersion(f, k, labels[:3])
    with pytest.raises(ValueError, match=r"pass wavenumber\.T"):
        plotting.plot_dispersion(f, k.T)


def test_plot_dispersion_k_lines_and_shared_legend(tmp_path):
    k = np.linspace(0, 20, 50)
    freqs = np.column_stack([k**2, 2 * k**2, 300 + 10 * k])
    ax = plotting.plot_dispersion_k(k, freqs, ["bending", "bending", "foot flapping"])
    assert len(ax.get_lines()) == 3
    assert ax.get_lines()[0].get_color() == ax.get_lines()[1].get_color()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["bending", "foot flapping"]
    save_and_check(ax, tmp_path, "dispersion_k.png")


def test_plot_magnitude_phase_two_axes(tmp_path):
    f = np.logspace(1, 4, 200)
    w = 2 * np.pi * f
    m, c, s = 60.0, 2e4, 2e8
    mobility = 1j * w / (s + 1j * w * c - m * w**2)
    values = np.column_stack([mobility, 0.5 * mobility])
    ax_mag, ax_phase = plotting.plot_magnitude_phase(f, values, ["point", "transfer"])
    assert ax_mag.figure is ax_phase.figure
    assert len(ax_mag.get_lines()) == 2 and len(ax_phase.get_lines()) == 2
    assert ax_mag.get_xscale() == "log" and ax_mag.get_yscale() == "log"
    phase = ax_phase.get_lines()[0].get_ydata()
    assert np.all(np.abs(phase) <= 180)
    save_and_check(ax_mag, tmp_path, "mobility.png")
    # a single 1-D response into provided axes
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1)
    out = plotting.plot_magnitude_phase(f, mobility, None, axes=axes,
                                        ylabel="Receptance (m/N)")
    assert out[0] is axes[0] and len(axes[0].get_lines()) == 1
    with pytest.raises(ValueError, match="got 1 labels for 2 curves"):
        plotting.plot_magnitude_phase(f, values, ["only one"])


def test_nominal_band_labels():
    centres = 1000 * 2.0 ** (np.arange(-17, 4) / 3)
    labels = [plotting.nominal_band_label(c) for c in centres]
    assert labels[:4] == ["20", "25", "31.5", "40"]
    assert labels[-5:] == ["800", "1k", "1.25k", "1.6k", "2k"]
    assert plotting.nominal_band_label(1000) == "1k"
    assert plotting.nominal_band_label(6300) == "6.3k"
    assert plotting.nominal_band_label(99.9) == "100"


def test_plot_band_values(tmp_path):
    centres = 1000 * 2.0 ** (np.arange(-15, 8) / 3)
    decay = np.column_stack([10 / np.sqrt(centres), 2 + 0 * centres])
    ax = plotting.plot_band_values(centres, decay, ["vertical", "lateral"], logy=True)
    assert len(ax.get_lines()) == 2
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert "31.5" in ticks and "1k" in ticks and "5k" in ticks
    assert ax.get_yscale() == "log"
    save_and_check(ax, tmp_path, "decay.png")
    with pytest.raises(ValueError, match="positive"):
        plotting.plot_band_values(-centres, decay)


def test_plot_along_rail(tmp_path):
    x = np.linspace(0, 30, 121)
    levels = np.column_stack([100 - 2 * x, 95 - 1.5 * x, 90 - x])
    ax = plotting.plot_along_rail(x, levels, ["500 Hz", "1k", "2k"])
    assert len(ax.get_lines()) == 3
    assert len(ax.get_legend().get_texts()) == 3
    save_and_check(ax, tmp_path, "along.png")
    with pytest.raises(ValueError, match=r"pass values\.T"):
        plotting.plot_along_rail(x, levels.T)


def test_plot_convergence_slopes_in_legend(tmp_path):
    h = np.array([0.02, 0.01, 0.005, 0.0025])
    errors = np.column_stack([3 * h**2, 40 * h**4])
    ax = plotting.plot_convergence(h, errors, ["P1", "P2"])
    assert len(ax.get_lines()) == 2
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == ["P1 (slope 2.00)", "P2 (slope 4.00)"]
    save_and_check(ax, tmp_path, "convergence.png")
    ax = plotting.plot_convergence(h, 3 * h**2, fit=False)
    assert len(ax.get_lines()) == 1 and ax.get_legend() is None
    assert np.isclose(plotting.convergence_slope(h, 5 * h**1.5), 1.5)
    assert np.isnan(plotting.convergence_slope(h[:1], h[:1]))


def test_draws_into_given_axes_and_saves_axes(tmp_path):
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 2)
    out = plotting.plot_along_rail([0, 1, 2], [1, 2, 3], ax=axs[1])
    assert out is axs[1]
    path = plotting.save_figure(axs[0], tmp_path / "deep" / "fig.pdf")
    assert path.exists() and path.read_bytes().startswith(b"%PDF")
    with pytest.raises(TypeError, match="Figure or Axes"):
        plotting.save_figure("not a figure", tmp_path / "x.png")
