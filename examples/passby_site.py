"""A train pass-by on the site track of METHOD.md Table 1 (Timoshenko beam models, fast).

    python examples/passby_site.py [OUT_DIR]

1. The simplified-method setting of METHOD.md section 8: continuous support, no
   interference between wheels, incoherent wheels, head sensor, no contact filter; the
   pass-by average in the 1 kHz band (tests/test_examples.py recomputes it from the
   formula v^2 = w^2 |Y r|^2 / |Y_rh + Y_w + Y_c|^2 N / (beta L)).
2. The discretely supported track with interaction and a time signal: the recording is
   read back as an estimator would read it.
The last lines are ``KEY <name> <value>`` in SI units.
"""
import sys
import tempfile
from pathlib import Path

from railfem.io.recording import read_recording
from railfem.jobs.passby import run_passby
from railfem.spec import preset
from railfem.wheelrail import contact


def main(out: Path) -> dict:
    track = preset("site", model="timoshenko-discrete")  # any TrackSpec: track.replace(kp=...)
    s1 = run_passby(out / "simplified", track=track, continuous=True,
                    interaction=False, output="head", contact_filter="none", f_low=200.0,
                    f_high=2000.0, before=42.0, after=42.0, max_distance=45.0)
    k = s1["band_hz"].index(1000.0)
    s2 = run_passby(out / "discrete", track=track, f_low=100.0, f_high=2000.0, signal=True,
                    noise_fraction=0.1, position_error=0.1, seed=1, before=20.0, after=20.0)
    rec = read_recording(Path(s2["files"]["recording_meta"]))
    print(f"pass-by levels (dB re 1e-9 m/s), discrete site track: "
          f"{dict(zip(s2['band_hz'], s2['passby_level_db']))}")
    print(f"exact - paper (dB): {dict(zip(s2['band_hz'], s2['exact_minus_paper_db']))}")
    return {"passby_level_1khz_db": s1["passby_level_db"][k],
            "contact_stiffness_n_per_m": contact.hertz().stiffness,
            "recording_duration_s": rec.duration}


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    for name, value in main(out).items():
        print(f"KEY {name} {value:.8g}")
