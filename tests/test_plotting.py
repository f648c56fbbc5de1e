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


# ------------------------------------------------------------------ dispersion branches
def synthetic_branches():
    from railfem.rail.branches import Branches

    f = np.linspace(50, 3000, 30)
    k_v = np.sqrt(2 * np.pi * f) * 0.12
    k_t = 2 * np.pi * f / 900.0               # crosses k_v
    k_w = np.where(f > 1300, np.sqrt(np.clip(f - 1300, 0, None)) * 0.2, np.nan)
    k = np.column_stack([k_v, k_t, k_w]).astype(complex)
    fr = np.where(np.isfinite(k.real), f[:, None], np.nan)
    labels = np.array(["vertical bending", "torsion", "cross-section (antisym.)"], dtype=object)
    point = np.broadcast_to(labels, k.shape).copy()
    point[20:, 1] = "lateral bending"         # the labeller switching along a branch
    return Branches(sweep="frequency", frequency=fr, k=k,
                    family=np.array(["symmetric", "antisymmetric", "antisymmetric"], dtype=object),
                    label=labels, name=np.array(["vertical bending", "torsion",
                                                 "antisymmetric cross-section wave"], dtype=object),
                    point_label=point, mac=np.ones(k.shape))


def test_plot_branches_one_line_colour_and_legend_entry_per_branch(tmp_path):
    br = synthetic_branches()
    ax = plotting.plot_branches(br)
    lines = ax.get_lines()
    assert len(lines) == 3
    assert len({ln.get_color() for ln in lines}) == 3
    assert [ln.get_linestyle() for ln in lines] == ["-", "--", "--"]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == list(br.name)
    # the torsion line carries all its points, on both sides of the crossing, in one colour
    assert np.count_nonzero(np.isfinite(lines[1].get_ydata())) == 30
    save_and_check(ax, tmp_path, "branches.png")


def test_branch_colours_follow_the_wave_type():
    colours = plotting.branch_colours(["torsion", "vertical bending", "torsion", "other"])
    assert colours[0] == plotting.TYPE_COLOURS["torsion"]
    assert colours[1] == plotting.TYPE_COLOURS["vertical bending"]
    assert len(set(colours)) == 4
    assert len(set(plotting.branch_colours(["x"] * 20))) == 20  # spare colours are distinct


def test_dispersion_job_legend_is_one_entry_per_branch_in_words(tmp_path, monkeypatch):
    """The omega(k) plot of the job used to append a family tag to each label ('... (sym.)
    (symm.)') and to drop the longitudinal branch from the legend."""
    from railfem.jobs.dispersion import run_dispersion

    seen = {}
    save = plotting.save_figure

    def capture(fig, path, **kw):
        ax = fig if hasattr(fig, "get_legend") else fig.axes[0]
        seen[path.name] = [t.get_text() for t in ax.get_legend().get_texts()]
        return save(fig, path, **kw)

    monkeypatch.setattr(plotting, "save_figure", capture)
    run_dispersion("rect:20x50", 0.01, tmp_path / "wk", k_values=np.linspace(0.2, 20, 12),
                   n_modes=4, render_frequency=None)
    legend = seen["dispersion.png"]
    assert "longitudinal" in legend
    assert len(legend) == len(set(legend))
    assert not any("(symm.)" in t or "(anti.)" in t or t.count("sym") > 1 for t in legend)
    run_dispersion("rect:20x50", 0.01, tmp_path / "kw",
                   frequencies=np.geomspace(100, 3000, 12), render_frequency=None)
    assert {"longitudinal", "vertical bending", "lateral bending", "torsion"} <= set(
        seen["dispersion.png"])


# --------------------------------------------------------------------------- decay rate
def decay_results(rate_of_band, spacing=0.6):
    """EN 15461 results of transfer mobilities decaying exactly at rate_of_band(centre)
    dB/m (constant inside each band) along the 29 standard positions."""
    from railfem.standards import en15461, iec61260

    f = iec61260.ninth_octave_grid(100.0, 5000.0)
    bands = iec61260.third_octave_bands(100.0, 5000.0)
    pos = en15461.hammer_positions(spacing)
    band_of_f = np.argmin(np.abs(np.log(f[:, None] / bands.centre[None, :])), axis=1)
    rate = rate_of_band(bands.nominal)[band_of_f]
    y = 10 ** (-rate[:, None] * pos[None, :] / 20)
    return en15461.decay_rate(f, y, pos), bands.nominal


def test_plot_decay_rate_log_axis_limit_curve_and_failed_bands(tmp_path):
    from railfem.standards import iso3095

    def rates(bands):
        r = np.where(bands < 1000, 8.0, 0.5)     # below the vertical limit from 1 kHz
        r[bands == 2000] = 0.1                   # a band below the EN 15461 D_min
        return r

    res, bands = decay_results(rates)
    centres = bands
    assert not res.suitable[centres == 2000][0]   # the generator made a failing band
    ax = plotting.plot_decay_rate_results([res], ["head sensor"], direction="vertical",
                                          cut_on={"foot flapping": 4500.0})
    assert ax.get_yscale() == "log" and ax.get_xscale() == "log"
    assert ax.get_ylabel() == "Track decay rate (dB/m)"
    limit = [ln for ln in ax.get_lines() if ln.get_gid() == "limit"]
    assert len(limit) == 1
    assert limit[0].get_ydata() == pytest.approx(iso3095.TRACK_DECAY_LIMIT_VERTICAL)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["head sensor", "EN 15461 lowest measurable D_min",
                      "ISO 3095 lower limit, vertical", "fails EN 15461 check (hollow)",
                      "below the ISO 3095 lower limit, vertical"]
    hollow = [ln for ln in ax.get_lines() if ln.get_markerfacecolor() == "white"
              and ln.get_label().startswith("_")]
    assert len(hollow) == 1 and 2000 in hollow[0].get_xdata()
    crosses = [ln for ln in ax.get_lines() if ln.get_marker() == "x" and ln.get_label()[0] == "_"]
    assert set(crosses[0].get_xdata()) == {b for b in bands if 1000 <= b <= 5000}
    assert any(t.get_text().strip() == "foot flapping cut-on 4.5 kHz" for t in ax.texts)
    save_and_check(ax, tmp_path, "decay_rate.png")


def test_plot_decay_rate_arrays_without_limits():
    centres = np.array([250.0, 500.0, 1000.0])
    ax = plotting.plot_decay_rate(centres, [[5.0, 6.0], [3.0, 2.0], [1.0, 0.5]],
                                  ["vertical", "lateral"])
    assert ax.get_yscale() == "log" and ax.get_legend() is not None
    assert not [ln for ln in ax.get_lines() if ln.get_gid() == "limit"]
    assert ax.get_ylim()[0] <= 0.1 and ax.get_ylim()[1] >= 100
    with pytest.raises(ValueError, match="same bands"):
        r1 = decay_results(lambda b: np.full(b.shape, 3.0))[0]
        r2 = type(r1)(**{**r1.__dict__, "frequency": r1.frequency * 2})
        plotting.plot_decay_rate_results([r1, r2])


# ----------------------------------------------------------- marks, mobility, along rail
def test_point_mobility_marks_named_frequencies(tmp_path):
    f = np.geomspace(50, 5000, 400)
    w = 2 * np.pi * f
    y = 1j * w / (1e8 + 1j * w * 1e4 - 30 * w**2)
    marks = {"sleeper on ballast": 90.0, "rail on pad": 290.0, "pinned-pinned": 1050.0,
             "outside": 20000.0}
    ax_mag, ax_phase = plotting.plot_point_mobility(f, y, ["head"], marks=marks)
    gids = [ln.get_gid() for ln in ax_mag.get_lines() if ln.get_gid()]
    assert gids == ["mark:sleeper on ballast", "mark:rail on pad", "mark:pinned-pinned"]
    texts = [t.get_text().strip() for t in ax_mag.texts]
    assert texts == ["sleeper on ballast 90 Hz", "rail on pad 290 Hz", "pinned-pinned 1.05 kHz"]
    assert len([ln for ln in ax_phase.get_lines() if ln.get_gid()]) == 3
    save_and_check(ax_mag, tmp_path, "point_mobility.png")


def test_along_rail_frequencies_are_distinct_and_inside_the_computed_range():
    from railfem.standards.iec61260 import ninth_octave_grid

    f = ninth_octave_grid(50.0, 1000.0)
    idx = plotting.along_rail_frequencies(f)
    assert len(idx) == 3 and len(set(idx)) == 3
    assert f[idx] == pytest.approx([250, 500, 1000], rel=0.04)
    # the old picker took the nearest grid point of each wanted frequency: 2000 Hz fell on
    # 1000 Hz, and below 250 Hz all four fell on the top frequency
    low = ninth_octave_grid(50.0, 200.0)
    idx = plotting.along_rail_frequencies(low)
    assert len(set(idx)) == len(idx) >= 3
    assert np.all((low[idx] >= 50) & (low[idx] <= 200))
    assert plotting.along_rail_frequencies([100.0]).tolist() == [0]


def test_plot_along_rail_distance_from_force_and_sleepers(tmp_path):
    x = np.round(np.arange(-6, 6.01, 0.1), 10)
    levels = np.column_stack([-3 * np.abs(x - 0.3), -2 * np.abs(x - 0.3)])
    ax = plotting.plot_along_rail(x, levels, ["250 Hz", "500 Hz"], x_force=0.3,
                                  supports=np.arange(-20, 21) * 0.6)
    assert ax.get_xlabel() == "Distance from the force (m)"
    assert ax.get_lines()[0].get_xdata()[np.argmax(levels[:, 0])] == pytest.approx(0.0)
    (sleepers,) = [ln for ln in ax.get_lines() if ln.get_gid() == "supports"]
    xs = sleepers.get_xdata()
    assert np.all((xs >= -6.3) & (xs <= 5.7)) and np.diff(xs) == pytest.approx(0.6)
    assert "sleeper (support)" in [t.get_text() for t in ax.get_legend().get_texts()]
    save_and_check(ax, tmp_path, "along_rail.png")


def test_plot_band_errors_returns_its_axes(tmp_path):
    """The study job titles and saves the Axes plot_band_errors returns (it returned None
    for a while, which only the slow study test would have noticed)."""
    wavelength = np.array([0.2, 0.1, 0.05, 0.025])
    ax = plotting.plot_band_errors(wavelength, {"full": [0.5, -0.2, 0.1, 1.5],
                                                "simplified": [1.0, 0.3, -0.8, 2.0]})
    assert ax is not None and ax.xaxis_inverted()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["full", "simplified"]
    save_and_check(ax, tmp_path, "band_errors.png")


# ------------------------------------------------------------- figures a user can read
def text_boxes(ax):
    """Window extents (pixels) of the texts on ``ax``, left to right, after a draw."""
    ax.figure.canvas.draw()
    return sorted((t.get_window_extent() for t in ax.texts if t.get_text().strip()),
                  key=lambda b: b.x0)


FREE_60E1_CUT_ONS = [("antisymmetric cross-section wave", 1298.0),  # 60E1, h = 10 mm
                     ("antisymmetric cross-section wave", 3869.0),
                     ("foot flapping (axial)", 5039.0), ("foot flapping", 5139.0),
                     ("antisymmetric cross-section wave", 9429.0), ("foot flapping", 9726.0)]


@pytest.mark.parametrize("high, cut_on, figsize", [
    (5000.0, FREE_60E1_CUT_ONS[2:4], (6.4, 4.8)),   # the track job's pair
    (10000.0, FREE_60E1_CUT_ONS[2:4] + [("web bending", 5500.0)], (6.4, 4.8)),
    (10000.0, FREE_60E1_CUT_ONS, (6.4, 4.8)),       # every family of the free rail
    (10000.0, FREE_60E1_CUT_ONS, (4.0, 3.0)),
])
def test_cut_on_texts_do_not_overlap(high, cut_on, figsize):
    """Close cut-ons (5.04 and 5.14 kHz on 60E1) wrote their texts against each other or
    over each other: each text now keeps clear of the others (a gap of at least a third of
    its thickness) and every cut-on is named."""
    import matplotlib.pyplot as plt

    centres = 1000 * 2.0 ** (np.arange(-13, 11) / 3)
    centres = centres[centres <= high * 1.01]
    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    plotting.plot_decay_rate(centres, 10 / np.sqrt(centres), ["head"], cut_on=cut_on, ax=ax)
    ax.set_title("a title")
    boxes = text_boxes(ax)
    thickness = min(b.width for b in boxes)
    for a, b in zip(boxes, boxes[1:]):
        assert not a.overlaps(b)
        assert b.x0 - a.x1 >= thickness / 3, (a, b)
    texts = " ".join(t.get_text() for t in ax.texts)
    for name, f in cut_on:
        assert f"{name} cut-on {f / 1000:.3g} kHz" in texts
    assert len([ln for ln in ax.get_lines() if (ln.get_gid() or "").startswith("mark:")]) \
        == len(cut_on)


def test_track_job_names_the_foot_curve_a_transfer(tmp_path, monkeypatch):
    """The point-mobility figure of `railfem track` called its foot curve 'point, foot
    sensor'; the force is on the head, so it is a head-to-foot transfer."""
    from railfem import preset
    from railfem.jobs.track import JobSettings, run_track

    seen = {}
    save = plotting.save_figure

    def capture(fig, path, **kw):
        ax = fig if hasattr(fig, "get_legend") else fig.axes[0]
        legend = ax.get_legend()
        seen[path.name] = [t.get_text() for t in legend.get_texts()] if legend else []
        return save(fig, path, **kw)

    monkeypatch.setattr(plotting, "save_figure", capture)
    run_track(preset("site", model="timoshenko-discrete"), tmp_path / "t",
              job=JobSettings(f_low=100.0, f_high=160.0), cache=False)
    legend = seen["point_mobility.png"]
    assert legend == ["head force -> head response (point)",
                      "head force -> foot response (transfer)"]
    assert not any("point, foot" in t for texts in seen.values() for t in texts)


def test_fit_of_a_table_row_names_the_row_in_its_titles(tmp_path, monkeypatch):
    """tdr.png of a fitted decay-rate table row (SBB Niederwangen columns) said only
    'Decay rate, <model> fit': the title now names the row, its section and date."""
    import railfem as rf
    from railfem import models
    from railfem.jobs.fit import run_fit
    from railfem.standards import iec61260

    centres = iec61260.third_octave_bands(100, 5000).nominal
    spec = rf.preset("site", model="timoshenko-continuous")
    d = models.decay_rate(spec, iec61260.ninth_octave_grid(100, 5000), cache=False).decay_rate
    table = tmp_path / "sbb.csv"
    table.write_text("\n".join([
        "loc,sec,messdatum,temp,rail,dir," + ",".join(f"{c:g}" for c in centres),
        "Ni,B1,2012-09-12,10.6,li,v," + ",".join(f"{x:.3f}" for x in d),
        "Ni,B3,2013-01-29,-0.7,re,v," + ",".join(f"{1.1 * x:.3f}" for x in d)]) + "\n")
    titles, profile_axes = {}, []
    save = plotting.save_figure

    def capture(fig, path, **kw):
        ax = fig if hasattr(fig, "get_title") else fig.axes[0]
        titles[path.name] = ax.get_title()
        if path.name == "profiles.png":
            profile_axes.extend(ax.figure.axes)
        return save(fig, path, close=False, **kw)

    monkeypatch.setattr(plotting, "save_figure", capture)
    run_fit(table, tmp_path / "out", model="timoshenko-continuous", row=1,
            parameters=("kp", "kb"), n_starts=1, workers=1, profiles=("kp",))
    title = titles["tdr.png"]
    assert "row 1" in title and "B3" in title and "2013-01-29" in title
    assert "B1" not in title and "2012-09-12" not in title
    # the profile figure, drawn by railfem.plotting now
    from railfem.identify.profiling import CHI2_95

    (ax,) = profile_axes
    assert ax.get_xlabel() == "kp (N/m)" and ax.get_xscale() == "log"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["95 % threshold"]
    assert any(np.allclose(ln.get_ydata(), CHI2_95) for ln in ax.get_lines())


def test_plot_transfer_fit_pairs_share_a_colour(tmp_path):
    f = np.geomspace(100, 2000, 30)
    y = 1e-4 / (1 + 1j * f / 500)
    ax = plotting.plot_transfer_fit(f, y, 1.1 * y, "head x = 1.20 m")
    ax = plotting.plot_transfer_fit(f, 0.5 * y, 0.6 * y, "head x = 2.40 m", ax=ax)
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == [
        "head x = 1.20 m measured", "head x = 1.20 m fitted",
        "head x = 2.40 m measured", "head x = 2.40 m fitted"]
    assert lines[0].get_color() == lines[1].get_color() != lines[2].get_color()
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert np.allclose(lines[3].get_ydata(), 0.6 * np.abs(y))
    save_and_check(ax, tmp_path, "transfer.png")
    with pytest.raises(ValueError, match="one value per frequency"):
        plotting.plot_transfer_fit(f, y[:-1], y)


def test_an_estimator_that_rejected_every_band_says_so():
    """A 'slope fitting' legend entry used to stand for a curve with no point at all."""
    centres = np.array([250.0, 315.0, 400.0, 500.0])
    ax = plotting.plot_decay_rate_estimates(centres, {
        "energy iteration": ([3.0, 2.5, 2.0, 1.5], [0.1, 0.1, 0.2, 0.2]),
        "slope fitting": (np.full(4, np.nan), None)})
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["energy iteration", "slope fitting: every band rejected"]
    drawn = [ln for ln in ax.get_lines() if np.isfinite(np.asarray(ln.get_ydata(), float)).any()]
    assert drawn and all(ln.get_color() == drawn[0].get_color() for ln in drawn)  # one estimator


def test_candidate_scores_draw_the_held_out_gate():
    ax = plotting.plot_candidate_scores(["pad_frequency", "noise_floor"], [-40.0, 3.0],
                                        [0.35, 0.02], [True, False], gate=0.1)
    (right,) = [a for a in ax.figure.axes if a is not ax]
    (gate,) = [ln for ln in right.get_lines() if ln.get_gid() == "gate"]
    assert np.allclose(gate.get_ydata(), 10.0)  # % on the right axis
    legend = [t.get_text() for t in right.get_legend().get_texts()]
    assert any("gate" in t and "10 %" in t for t in legend)


def test_diagnose_job_draws_the_gate_of_its_rules(tmp_path, monkeypatch):
    """candidates.png had no gate line: the job passes the diagnosis's MIN_GAIN. The
    before/after figure (one panel per data part) is drawn by railfem.plotting."""
    from types import SimpleNamespace

    from railfem.diagnosis.gates import MIN_GAIN
    from railfem.jobs.diagnose import figures

    class NoResidual:
        def select(self, **kw):
            return []

        def band_table(self, bands):
            return [{"part": part, "quantity": "transfer", "band_hz": b, "rms_db": r, "n": 4}
                    for part, r in (("fit", 1.5), ("held", 2.5)) for b in (125.0, 250.0)]

    d = SimpleNamespace(
        residual_before=NoResidual(), residual_after=None,
        candidates=[{"name": "pad_frequency", "delta_bic": -40.0, "kept": True,
                     "held_out": {"reduction": 0.35}},
                    {"name": "noise_floor", "delta_bic": 3.0, "kept": False,
                     "held_out": {"reduction": None}}],
        data=SimpleNamespace(records=[SimpleNamespace(
            fit=SimpleNamespace(frequency=np.array([100.0, 2000.0])))]))
    drawn = {}
    save = plotting.save_figure

    def capture(fig, path, **kw):
        drawn[path.name] = getattr(fig, "figure", fig)
        return save(fig, path, close=False, **kw)

    monkeypatch.setattr(plotting, "save_figure", capture)
    figures(tmp_path, d)
    gates = [ln for a in drawn["candidates.png"].axes for ln in a.get_lines()
             if ln.get_gid() == "gate"]
    assert len(gates) == 1 and np.allclose(gates[0].get_ydata(), 100 * MIN_GAIN)
    panels = drawn["before_after_transfer.png"].axes
    assert [a.get_title() for a in panels] == ["transfer: residual RMS per band, fit data",
                                               "transfer: residual RMS per band, held data"]
    assert [t.get_text() for t in panels[1].get_xticklabels()] == ["125", "250"]
    heights = [p.get_height() for p in panels[1].patches]
    assert heights[:2] == [2.5, 2.5] and np.isnan(heights[2:]).all()  # no 'after' model


@pytest.mark.parametrize("wavelength", [
    np.geomspace(0.25, 0.025, 11),   # 25 - 2.5 cm without the limit curve
    np.geomspace(0.1, 0.01, 11),
])
@pytest.mark.parametrize("limit", [True, False])
def test_roughness_wavelength_axis_has_four_or_more_labels(wavelength, limit):
    """roughness.png had two labelled wavelength ticks (1 and 10 cm) over 2.3 decades."""
    ax = plotting.plot_roughness(wavelength, {"combined": np.linspace(5, -5, 11)},
                                 limit=limit)
    ax.figure.canvas.draw()
    low, high = sorted(ax.get_xlim())
    shown = [t.get_text() for t in ax.get_xticklabels() + ax.get_xticklabels(minor=True)
             if t.get_text() and low <= t.get_position()[0] <= high]
    assert len(shown) >= 4, shown
    assert all(float(s) > 0 for s in shown)  # plain numbers (cm)


@pytest.mark.parametrize("positions, scale, left", [
    ([0.02, 0.3, 0.6, 1.2, 3.0, 7.2, 16.8], "log", None),
    ([0.0, 0.3, 0.6, 1.2, 3.0, 7.2], "symlog", 0.0),
    ([-1.2, -0.3, 0.02, 0.6, 3.0], "symlog", None),
])
def test_residual_distance_scale_fits_the_distances(positions, scale, left):
    """residual_distance.png drew a symlog axis with an empty negative half."""
    values = np.column_stack([np.linspace(-2, 2, len(positions))] * 2)
    ax = plotting.plot_residual_distance(positions, values, ["250 Hz", "1k"])
    assert ax.get_xscale() == scale
    lo, hi = ax.get_xlim()
    if left is not None:
        assert lo == left
    assert lo <= min(positions) and hi >= max(positions)
    if min(positions) >= 0:
        assert lo >= 0  # no empty negative half
    if scale == "log":  # plain labels: 0.02 ... 16.8 m is 3 decades, decade ticks give 2
        ax.figure.canvas.draw()
        shown = [t.get_text() for t in ax.get_xticklabels() if t.get_text()
                 and lo <= t.get_position()[0] <= hi]
        assert len(shown) >= 4 and all(float(s) > 0 for s in shown), shown
