"""The diagnosis's verdict in words: what the base model, the chosen effect and the
remaining residual say, with the candidates that failed or were rejected after their final
refit named (railfem.diagnosis.loop calls :func:`decide` at its end)."""
from __future__ import annotations

from railfem.diagnosis import residual as resid

__all__ = ["decide"]


def explains_residual(st: dict) -> bool:
    return (st["verdict"] in ("noise", "consistent")
            or st["structured_rms_db"] < resid.NEGLIGIBLE_DB)


def _left(st: dict) -> str:
    """What the remaining residual is consistent with, in words."""
    if st["verdict"] == "consistent" and st["structured_rms_db"] >= resid.NEGLIGIBLE_DB:
        d = st["discrepancy"]
        return (f"noise plus the model's own discretisation discrepancy (structured part "
                f"{st['structured_rms_db']:.2f} dB, discrepancy {d['discrepancy_rms_db']:.2f} "
                f"dB RMS, {st['structured_beyond_discrepancy_db']:.2f} dB beyond it)")
    return f"noise (structured part {st['structured_rms_db']:.2f} dB)"


def _failed(failures) -> str:
    if not failures:
        return ""
    return ("; not judged (failed): "
            + ", ".join(f"{f['candidate']} at {f['stage']}" for f in failures))


def decide(st_before, st_after, chosen, chosen_row, rows, failures=()) -> tuple[str, str]:
    """(verdict, plain statement). Verdicts: 'noise' (the base explains the data),
    'consistent' (the base explains the data up to noise plus its model-form
    discrepancy), 'explained', 'partly explained', 'unexplained'. Candidates rejected
    after their final refit and candidates that failed are named in the statement."""
    fails = _failed(failures)
    late = [r for r in rows if r.get("final_rejected")]
    why = "".join(f"; {r['name']} passed the screening gates but not after its final "
                  f"refit: {r['final_rejected']}" for r in late)
    if chosen is None and st_before["verdict"] == "consistent" and \
            st_before["structured_rms_db"] >= resid.NEGLIGIBLE_DB:
        return "consistent", ("the data are consistent with the model: the base model's "
                              "residual is within " + _left(st_before) + "; no effect is "
                              "claimed" + why + fails)
    if explains_residual(st_before) and chosen is None:
        return "noise", ("the base model explains the data: its residual is consistent with "
                         f"noise (p = {st_before['p']:.3g}, structured part "
                         f"{st_before['structured_rms_db']:.2f} dB); no effect is claimed"
                         + why + fails)
    if chosen is None:
        best = rows[0]["name"] if rows else "none"
        return "unexplained", ("no candidate explains the residual: no effect of the library "
                               "passes the plausibility and held-out gates (best by BIC: "
                               f"{best}){why}; the unexplained residual is shown" + fails)
    red = chosen_row["final_held_out"].get("reduction") or 0.0
    if explains_residual(st_after):
        return "explained", (f"{chosen.name} explains the residual: held-out error down "
                             f"{100 * red:.0f} %, remaining residual consistent with "
                             + _left(st_after) + why + fails)
    return "partly explained", (f"{chosen.name} improves the fit (held-out error down "
                                f"{100 * red:.0f} %) but structure remains (structured part "
                                f"{st_after['structured_rms_db']:.2f} dB): no candidate fully "
                                "explains the residual" + why + fails)
