"""Verdicts on the paper's claims, computed from measured labels and numbers.

Every function takes an item's measured table (:func:`analysis.paper.measure.measure_runs`) and
returns verdict rows ``{item, claim, measured, verdict}``; ``verdict`` is one of
:data:`VERDICTS`.  The rules (docs/paper-reproduction.md states each with its numbers):

* a claimed regular regime is ``reproduced`` when our label at every mapped point is the
  claimed one; a claimed chaos when one mapped run or more is chaotic (the mapping is uncertain
  and chaotic windows are narrow);
* a claimed chaos with the paper's friction law (``mu_s = mu_k``) that we do not find, with
  ``lambda_1 T`` at most the Lyapunov resolution, is ``not reproduced: impossible in a
  consistent model`` (docs/lyapunov.md, section 8: a monotone friction law makes the model
  non-expansive, ``lambda_1 <= 0``);
* ``reproduced qualitatively`` where the claim holds but depends on a mapping choice or holds in
  part (e.g. a slower approach that ends on a limit cycle instead of a torus, a trend that is
  there from the smallest to the largest load but not monotone);
* ``unsettled`` and ``diverged`` runs neither confirm nor contradict a claimed regime: they are
  named in the measured text and left out of the judgement;
* ``false as stated`` where the measured numbers contradict the claim;
* ``not reproduced: data missing`` where the paper's numbers are needed and not given.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.paper.measure import drawn
from analysis.paper.runs import PAPER_LAW
from analysis.pipeline.stages import poincare_array

__all__ = ["VERDICTS", "REPRODUCED", "QUALITATIVE", "IMPOSSIBLE", "DATA_MISSING", "FALSE",
           "labels_text", "pre_slip_verdict", "table1_verdicts", "fig8_verdicts", "fig9_verdicts",
           "fig10_verdicts", "fig11_verdicts", "fig12_verdicts", "fig13_verdicts", "verdict_table",
           "history_difference", "settling_periods", "MODE_TOLERANCE", "SHAPE_TOLERANCE",
           "SETTLED_TOLERANCE"]

REPRODUCED = "reproduced"
QUALITATIVE = "reproduced qualitatively"
IMPOSSIBLE = "not reproduced: impossible in a consistent model"
DATA_MISSING = "not reproduced: data missing"
FALSE = "false as stated"
#: the fixed vocabulary of the verdicts table
VERDICTS = (REPRODUCED, QUALITATIVE, IMPOSSIBLE, DATA_MISSING, FALSE)

#: relative tolerance of Table 1's frequency ratios (the paper prints 5 digits of ANSYS values)
TABLE1_TOLERANCE = 0.01
#: a mode count is converged when its tip history is within this fraction of the amplitude of
#: the largest mode count's
MODE_TOLERANCE = 0.05
#: two laws give "different" attractors when their tip histories differ by more than this
#: fraction of the amplitude
SHAPE_TOLERANCE = 0.05
#: the Poincare samples have settled when they stay within this fraction of their range of the
#: last sample
SETTLED_TOLERANCE = 0.01


def _row(item: str, claim: str, measured: str, verdict: str) -> dict:
    if verdict not in VERDICTS:
        raise ValueError(f"verdict {verdict!r} not in the vocabulary {VERDICTS}")
    return {"item": item, "claim": claim, "measured": measured, "verdict": verdict}


def _label(row: pd.Series) -> str:
    lab = str(row["label"])
    if lab == "periodic" and pd.notna(row.get("period")):
        return f"period {int(row['period'])}"
    return lab


def labels_text(rows: pd.DataFrame) -> str:
    """``"f0_rel 1.05: period 1 (lambda_1 T -0.02); ..."`` for the rows of one law."""
    parts = []
    for _, r in rows.iterrows():
        where = f"f0_rel {r['f0_rel']:.3g}" if "f0_rel" in r else ""
        parts.append(f"{where}: {_label(r)} (lambda_1 T {r['lle_T']:+.3f})")
    return "; ".join(parts)


def history_difference(a: pd.Series, b: pd.Series, key: str = "w") -> float:
    """Largest difference of two dense histories (same time grid) over the peak-to-peak range
    of ``b``."""
    x, y = np.asarray(a[key], dtype=float), np.asarray(b[key], dtype=float)
    n = min(x.size, y.size)
    if n == 0 or not (np.all(np.isfinite(x[:n])) and np.all(np.isfinite(y[:n]))):
        return float("nan")
    span = float(np.ptp(y[:n])) or 1.0
    return float(np.max(np.abs(x[:n] - y[:n])) / span)


def settling_periods(poincare_w: np.ndarray, tol: float = SETTLED_TOLERANCE) -> int | None:
    """First period after which the Poincare samples stay within ``tol`` of their range of the
    last sample (the length of the run when they never do).  Sample 0 (the state at rest) is
    left out of the range.  None for a record that is not finite (a diverged run)."""
    w = np.asarray(poincare_w, dtype=float)[1:]
    if w.size == 0 or not np.all(np.isfinite(w)):
        return None
    span = float(np.ptp(w)) or 1.0
    far = np.nonzero(np.abs(w - w[-1]) > tol * span)[0]
    return int(far[-1] + 2) if far.size else 1


# ------------------------------------------------------------------------------ items
def table1_verdicts(ratios: np.ndarray) -> list[dict]:
    """Table 1 (alpha = 0.01, beta = 0.4): f2/f1 and f3/f1 from ANSYS 22.72, 139.19, 393.12 Hz."""
    paper = np.array([139.19 / 22.72, 393.12 / 22.72])
    ours = np.asarray(ratios, dtype=float)[1:3]
    rel = ours / paper - 1.0
    ok = bool(np.all(np.abs(rel) <= TABLE1_TOLERANCE))
    measured = (f"f2/f1 {ours[0]:.4f} (paper {paper[0]:.4f}, {100 * rel[0]:+.2f} %), "
                f"f3/f1 {ours[1]:.4f} (paper {paper[1]:.4f}, {100 * rel[1]:+.2f} %)")
    return [_row("modes", "Table 1: f2/f1 = 6.126, f3/f1 = 17.30 (alpha 0.01, beta 0.4, clamped-free)",
                 measured, REPRODUCED if ok else FALSE)]


def fig8_verdicts(measured: pd.DataFrame) -> list[dict]:
    """Fig 8: three modes agree with the FE model.  Our check: the tip history with N modes
    against the largest N run (the paper's FE histories are not published)."""
    out = []
    for case, df in measured.groupby("case", sort=False):
        df = df.sort_values("n_modes")
        ref = df.iloc[-1]
        diffs = {int(r["n_modes"]): max(history_difference(r, ref, "w"), history_difference(r, ref, "u1"))
                 for _, r in df.iloc[:-1].iterrows()}
        converged = [n for n in sorted(diffs) if all(diffs[m] <= MODE_TOLERANCE for m in diffs if m >= n)]
        n_conv = converged[0] if converged else None
        text = ", ".join(f"N={n}: {100 * d:.1f} %" for n, d in diffs.items())
        measured_text = (f"{case}: tip w and u1 against N={int(ref['n_modes'])}, largest difference over "
                         f"the amplitude: {text}; converged (<= {100 * MODE_TOLERANCE:g} %) from "
                         f"N={n_conv if n_conv else 'none'}; the FE histories and Fig 8's load are not "
                         "published")
        three = diffs.get(3)
        if three is None or not np.isfinite(three) or not np.isfinite(list(diffs.values())).all():
            verdict = DATA_MISSING
        else:
            verdict = REPRODUCED if three <= MODE_TOLERANCE else FALSE
        out.append(_row("fig8", f"Fig 8 ({case}): three mode shapes give the converged (FE) tip response",
                        measured_text, verdict))
    return out


#: labels that are not a regime: the run could not decide (docs/classification.md): still a
#: transient, diverged, or ``undetermined`` (the record does not decide between regimes, e.g. a
#: stuck record whose free vibration can still reach a slip limit: rule 3)
NON_RESULTS = ("unsettled", "diverged", "undetermined")


def _limit_cycle_verdict(rows: pd.DataFrame) -> str:
    """A claimed limit cycle (a fixed point of the Poincare map) at every mapped point, judged
    on the points that reached a regime (:data:`NON_RESULTS` neither confirm nor contradict, nor
    does a label given by the shakedown limit alone, whose record did not reach its attractor:
    :data:`analysis.pipeline.stages.BY_SHAKEDOWN`):
    period 1 everywhere -> reproduced; periodic (any period) at one point or more and
    quasi-periodic at most elsewhere -> reproduced qualitatively; otherwise (chaos, or no
    periodic point) -> false as stated; no point settled -> data missing."""
    from analysis.pipeline.stages import BY_SHAKEDOWN

    reached = ~rows["reason"].astype(str).str.startswith(BY_SHAKEDOWN) if "reason" in rows else True
    settled = rows[~rows["label"].isin(NON_RESULTS) & reached]
    if settled.empty:
        return DATA_MISSING
    labels = set(settled["label"])
    if labels == {"periodic"} and set(settled["period"]) == {1}:
        return REPRODUCED
    # qualitatively: periodic somewhere, nothing but periodic and quasi-periodic anywhere
    return QUALITATIVE if "periodic" in labels and labels <= {"periodic", "quasi-periodic"} else FALSE


def _chaos_verdict(paper: pd.DataFrame, resolution: float) -> tuple[str, str]:
    """A chaos claim made with the paper's law, over its mapped runs (the mapping is uncertain
    and chaotic windows are narrow, so one chaotic mapped run reproduces it): chaotic at one run
    or more -> reproduced; no run with a value -> data missing; ``lambda_1 T`` above the
    resolution without the chaotic label -> reproduced qualitatively (a positive exponent the
    other indicators do not confirm); every ``lambda_1 T`` (unsettled runs included) at most the
    resolution -> impossible in a consistent model (the proof of docs/lyapunov.md section 8).

    A periodic run without a confidence interval (``lle_lo_T`` missing: the pipeline did not
    measure the long record, because the period test over the whole record excludes chaos;
    :func:`analysis.pipeline.stages.long_record_exemption`) carries only the short window's
    reading, whose own resolution is far coarser than the margin; it counts as ``lambda_1 T <=
    0`` (an attracting periodic orbit), and a positive window reading is named in the text."""
    lle = paper["lle_T"].to_numpy(dtype=float) if len(paper) else np.array([])
    if (paper["label"] == "chaotic").any():
        return REPRODUCED, ""
    if lle.size == 0 or not np.isfinite(lle).any():
        return DATA_MISSING, ". No paper-law run with a Lyapunov exponent"
    note = ""
    if "lle_lo_T" in paper:
        window_only = ((paper["label"] == "periodic").to_numpy()
                       & ~np.isfinite(paper["lle_lo_T"].to_numpy(dtype=float)) & np.isfinite(lle))
        if np.any(window_only & (lle > 0.0)):
            note = (f" (window readings of periodic runs, up to {np.max(lle[window_only]):+.3f}, count as"
                    " <= 0: the period test labels those runs, the long record was not run)")
        lle = np.where(window_only, np.minimum(lle, 0.0), lle)
    top = float(np.nanmax(lle))
    if top <= resolution:
        return IMPOSSIBLE, (f". Largest lambda_1 T with the paper's law {top:+.3f} <= resolution "
                            f"{resolution:g}{note}, as docs/lyapunov.md section 8 proves")
    return QUALITATIVE, (f". Largest lambda_1 T {top:+.3f} > resolution {resolution:g}{note}, "
                         "not labelled chaotic")


def _chaos_row(item: str, claim: str, df: pd.DataFrame, resolution: float) -> dict:
    """A chaos claim (:func:`_chaos_verdict`) with the runs at mu_s > mu_k named beside it."""
    paper = df[df["law"] == PAPER_LAW]
    other = df[df["law"] != PAPER_LAW]
    text = f"paper's law: {labels_text(paper)}"
    for law, rows in other.groupby("law", sort=False):
        n_ch = int((rows["label"] == "chaotic").sum())
        text += f". {law}: chaotic at {n_ch} of {len(rows)} ({labels_text(rows)})"
    verdict, why = _chaos_verdict(paper, resolution)
    return _row(item, claim, text + why, verdict)


def fig9_verdicts(df: pd.DataFrame, resolution: float) -> list[dict]:
    """Fig 9a-b (two limit cycles of different shape), 9c (stick-slip chaos), 9d (full-slip limit
    cycle) from the fig9 item's runs; ``resolution``: the smallest ``lambda_1 T`` resolved."""
    out = []
    ab = df[df["case"] == "(a, b)"]
    ss, fs = ab[ab["law"] == PAPER_LAW], ab[ab["law"] == "full-slip"]
    labels = set(ss["label"]) | set(fs["label"])
    drawn_ss, drawn_fs = drawn(ss), drawn(fs)
    text = f"stick-slip: {labels_text(ss)}; full-slip: {labels_text(fs)}"
    if len(drawn_ss) and len(drawn_fs):
        diff = history_difference(drawn_ss.iloc[0], drawn_fs.iloc[0])
        text += (f"; tip histories differ by {100 * diff:.1f} % of the full-slip amplitude "
                 f"(f0_rel {drawn_fs['f0_rel'].iloc[0]:.3g})")
    else:
        diff = np.nan
    cycles = [_limit_cycle_verdict(ss), _limit_cycle_verdict(fs)]
    if FALSE in cycles or "chaotic" in labels:
        verdict = FALSE
    elif DATA_MISSING in cycles or not np.isfinite(diff):
        verdict = DATA_MISSING
    else:  # limit cycles of "completely different" structure: a difference above the tolerance
        verdict = QUALITATIVE if diff > SHAPE_TOLERANCE else FALSE
    out.append(_row("fig9", "Fig 9a-b: stick-slip and full-slip both settle on limit cycles, of different "
                    "shape", text, verdict))
    cd = df[df["case"] == "(c, d)"]
    out.append(_chaos_row("fig9", "Fig 9c: stick-slip is chaotic (two irregular tori)",
                          cd[cd["law"] != "full-slip"], resolution))
    fs = cd[cd["law"] == "full-slip"]
    verdict = _limit_cycle_verdict(fs)
    out.append(_row("fig9", "Fig 9d: full-slip at the same parameters goes to a limit cycle",
                    f"full-slip: {labels_text(fs)}", verdict))
    return out


def pre_slip_verdict(rows: pd.DataFrame) -> dict:
    """Fig 10a: below the initial slip the response is a torus.  The premise is measured: a run
    is "before the initial slip" when it never slipped (``slipped`` False).  Where no mapped run
    meets the premise, the claim cannot be tested with the paper's data (its frequency and
    initial state are not given)."""
    slipped = rows["slipped"].astype(bool)
    stuck = rows[~slipped]
    text = f"{labels_text(rows)}; slipped at {int(slipped.sum())} of {len(rows)}"
    if "stick_fraction" in rows:
        text += f" (stuck fraction of the recorded periods {rows['stick_fraction'].min():.3f}-" \
                f"{rows['stick_fraction'].max():.3f})"
    if stuck.empty:
        verdict = DATA_MISSING
        text += "; no mapped run stays before the initial slip (the start from rest overshoots it)"
    elif stuck["label"].isin(NON_RESULTS).all():
        verdict = DATA_MISSING
    else:
        labels = set(stuck["label"]) - set(NON_RESULTS)
        verdict = (REPRODUCED if labels == {"quasi-periodic"} else
                   QUALITATIVE if labels <= {"quasi-periodic", "periodic"} else FALSE)
    return _row("fig10", "Fig 10a: f0 = 0.5, before the initial slip, a torus (quasi-periodic)", text,
                verdict)


def _slower_approach_row(df: pd.DataFrame) -> dict:
    """Fig 10f: at f0 = 10 the Poincare samples approach more slowly than at f0 = 5, and end on
    a torus.  The approach is measured by :func:`settling_periods` on the transient runs from
    rest, which is a rate only where both runs end on a fixed point (label period 1 at the
    middle anchor); otherwise the rate part cannot be judged (data missing)."""
    claim = "Fig 10f: f0 = 10, the Poincare samples approach more slowly and end on a stable torus"
    cls = df[df["kind"] == "classified"]
    tr = df[df["kind"] == "transient"].set_index("case")
    ten = cls[(cls["case"] == "f0=10") & ~cls["label"].isin(NON_RESULTS)]
    if not {"f0=5", "f0=10"} <= set(tr.index):
        return _row("fig10", claim, "no transient runs at f0 = 5 and 10", DATA_MISSING)
    ends = {}
    for case in ("f0=5", "f0=10"):
        mid = cls[(cls["case"] == case) & (cls["anchor"] == tr.loc[case, "anchor"])]
        ends[case] = bool(len(mid)) and mid["label"].iloc[0] == "periodic" and mid["period"].iloc[0] == 1
    s5 = settling_periods(poincare_array(tr.loc["f0=5", "poincare_tip"])[:, 0])
    s10 = settling_periods(poincare_array(tr.loc["f0=10", "poincare_tip"])[:, 0])
    n = len(tr.loc["f0=5", "poincare_tip"]) - 1
    text = f"f0=10: {labels_text(cls[cls['case'] == 'f0=10'])}"
    if not all(ends.values()) or s5 is None or s10 is None:
        return _row("fig10", claim, text + "; the approach rate is measured only where both transients end "
                    "on period 1", DATA_MISSING)
    text = (f"Poincare samples from rest settle (within {100 * SETTLED_TOLERANCE:g} % of their range) "
            f"after {s5} periods at f0=5 and {s10} at f0=10 (of {n}); " + text)
    labels = set(ten["label"])
    slower = s10 > s5
    verdict = (REPRODUCED if slower and labels == {"quasi-periodic"} else
               QUALITATIVE if slower and labels else FALSE)
    return _row("fig10", claim, text, verdict)


def fig10_verdicts(df: pd.DataFrame, resolution: float) -> list[dict]:
    """Fig 10a-f and the load sweep's chaos claim from the fig10 item's runs."""
    cls = df[df["kind"] == "classified"]
    out = []
    out.append(pre_slip_verdict(cls[cls["case"] == "f0=0.5"]))
    out.append(_chaos_row("fig10", "Fig 10b-c: f0 = 1, after the initial slip, a strange attractor",
                          cls[cls["case"] == "f0=1"], resolution))
    five = cls[cls["case"] == "f0=5"]
    out.append(_row("fig10", "Fig 10d-e: f0 = 5, a fixed point of the Poincare map (limit cycle)",
                    labels_text(five) or "no run at f0 = 5", _limit_cycle_verdict(five)))
    out.append(_slower_approach_row(df))
    sweep = cls[cls["case"] == "load sweep"]
    text = []
    for law, rows in sweep.groupby("law", sort=False):
        text.append(f"{law}: chaotic at {int((rows['label'] == 'chaotic').sum())} of {len(rows)} loads "
                    f"(f0_rel {rows['f0_rel'].min():.3g}-{rows['f0_rel'].max():.3g}), "
                    f"largest lambda_1 T {rows['lle_T'].max():+.3f}")
    verdict, _ = _chaos_verdict(sweep[sweep["law"] == PAPER_LAW], resolution)
    out.append(_row("fig10", "Section 4.3 and conclusions: after the initial slip the beam has chaotic "
                    "regimes (load sweep)", "; ".join(text), verdict))
    return out


def fig11_verdicts(measured: pd.DataFrame, resolution: float) -> list[dict]:
    """Fig 11's chaos claim from the fig11 item's runs."""
    return [_chaos_row("fig11", "Fig 11: chaotic after the initial slip (axial phase planes, Poincare maps)",
                       measured, resolution)]


def fig12_verdicts(F_s: float, F_c: float, v_s: float, k_v: float, eps: float) -> list[dict]:
    """Fig 12 / eq 34: the traction falls from F_s at zero slip rate to F_c, plus k_v v."""
    from beamsim.friction import smooth_traction

    v0 = 30.0 * eps                    # past the regularisation band, far below v_s
    vinf = 30.0 * v_s
    t0 = smooth_traction(v0, F_c, F_s, v_s, k_v, eps)
    tinf = smooth_traction(vinf, F_c, F_s, v_s, k_v, eps)
    e0 = abs(t0 - (F_c + (F_s - F_c) * np.exp(-v0 / v_s) + k_v * v0)) / F_s
    einf = abs(tinf - (F_c + k_v * vinf)) / F_s
    ok = e0 < 1e-6 and einf < 1e-6 and t0 > tinf
    text = (f"traction {t0 / F_s:.4f} F_s at v = {v0:.2g} and {tinf / F_s:.4f} F_s at v = {vinf:.2g} "
            f"(eq 34: F_c + k_v v = {(F_c + k_v * vinf) / F_s:.4f} F_s); deviation from eq 34 "
            f"{max(e0, einf):.1e} F_s")
    return [_row("fig12", "Fig 12 / eq 34: Stribeck traction falls from F_s at zero slip rate to F_c + k_v v",
                 text, REPRODUCED if ok else FALSE)]


def fig13_verdicts(df: pd.DataFrame) -> list[dict]:
    """Fig 13: a limit cycle with both laws at every load, and the laws' difference falling with
    the load (monotone: reproduced; only from the smallest to the largest load: qualitatively)."""
    out, diffs = [], []
    for case, rows in df.groupby("case", sort=False):
        dry, st = rows[rows["law"] != "Stribeck"], rows[rows["law"] == "Stribeck"]
        d_dry, d_st = drawn(dry), drawn(st)
        diff = history_difference(d_st.iloc[0], d_dry.iloc[0]) if len(d_dry) and len(d_st) else np.nan
        diffs.append((float(rows["f0_paper"].iloc[0]), diff))
        text = f"dry: {labels_text(dry)}; Stribeck: {labels_text(st)}; histories differ by {100 * diff:.1f} %"
        out.append(_row("fig13", f"Fig 13 ({case}): dry and Stribeck friction both give a limit cycle "
                        "(a fixed point of the Poincare map)", text, _limit_cycle_verdict(rows)))
    diffs.sort()
    values = [d for _, d in diffs]
    decreasing = all(b < a for a, b in zip(values, values[1:]))
    text = ", ".join(f"f0={f:g}: {100 * d:.1f} %" for f, d in diffs)
    # monotone: reproduced; smaller at the largest load than at the smallest only: qualitatively
    verdict = (DATA_MISSING if len(values) < 2 or not np.all(np.isfinite(values)) else
               REPRODUCED if decreasing else QUALITATIVE if values[-1] < values[0] else FALSE)
    out.append(_row("fig13", "Fig 13: the lubricant's effect on the response decreases as f0 grows",
                    f"dry against Stribeck tip-history difference over the amplitude: {text}", verdict))
    return out


def verdict_table(measured: dict[str, pd.DataFrame], *, modes, stribeck: dict,
                  resolution: float) -> pd.DataFrame:
    """Every verdict row, in the paper's order: Table 1 from ``modes``
    (:func:`analysis.paper.runs.paper_modes`), fig 12 from the ``stribeck`` constants, the others
    from each item's measured table; ``resolution``: the smallest ``lambda_1 T`` resolved."""
    rows = table1_verdicts(modes.frequency_ratios)
    rows += fig8_verdicts(measured["fig8"])
    rows += fig9_verdicts(measured["fig9"], resolution)
    rows += fig10_verdicts(measured["fig10"], resolution)
    rows += fig11_verdicts(measured["fig11"], resolution)
    rows += fig12_verdicts(**stribeck)
    rows += fig13_verdicts(measured["fig13"])
    return pd.DataFrame(rows, columns=["item", "claim", "measured", "verdict"])
