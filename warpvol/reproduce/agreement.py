"""Agreement of the throughput model with the papers' timings, by role (``scripts/validate_model.py``).

An absolute row compares a modelled figure with a paper's: its role is ``prediction`` or ``calibration on
ROW`` (a profile constant was fitted to ROW, this row or one whose fitted constant makes most of this
row's time). A relative row (A over B) takes its role from its two absolute rows: ``prediction`` when both
are predictions (only these make the count), ``one calibration row`` (its ratio is the predicted row's
modelled / paper over the calibration row's, which is 1 only where the fit is exact; counted apart),
``calibration only`` (not a prediction, not counted). A relative row's modelled / paper is A's over B's,
so the rows are not independent: :func:`independent_ratios` says how many independent ratios they rest
on. This module holds those roles, the counts, the sensitivity notes of rows resting on one estimated
constant and the JSON the docs render (``docs/data/validate_model.json``), and reads that JSON back.
"""

from __future__ import annotations

import json


def fmt_ratio(v) -> str:
    """A ratio as the tables print it (two decimals; "-" when not modelled)."""
    return "-" if v is None else f"{v:.2f}"


def sensitivity(paper: float | None, at, what: str) -> str:
    """What an agreement rests on: modelled / paper at half and at double one estimated constant."""
    lo, hi = (None if v is None or not paper else v / paper for v in at)
    return f"sensitivity: ratio {fmt_ratio(lo)} at half, {fmt_ratio(hi)} at double {what}"


#: a relative row's role from the roles of its two absolute rows (the counts take ``prediction`` rows only)
REL_PREDICTION, REL_ONE_CAL, REL_CAL_ONLY = "prediction", "one calibration row", "calibration only"


def relative_role(role_a: str, role_b: str) -> str | None:
    """``prediction`` (both rows predicted), ``one calibration row`` (one of them fitted: the relative ratio
    is the other row's over the fitted row's), ``calibration only`` (both fitted: not a prediction); None
    when either row is not modelled."""
    cal = [r.startswith("calibration") for r in (role_a, role_b)]
    if any(r not in ("prediction",) and not c for r, c in zip((role_a, role_b), cal)):
        return None
    return (REL_PREDICTION, REL_ONE_CAL, REL_CAL_ONLY)[sum(cal)]


def relative_counts(relative: list[dict]) -> dict:
    """role -> (agreeing, rows with both values) over the relative rows."""
    out = {}
    for role in (REL_PREDICTION, REL_ONE_CAL, REL_CAL_ONLY):
        rs = [r for r in relative if r["role"] == role and r["agrees"] is not None]
        out[role] = (sum(bool(r["agrees"]) for r in rs), len(rs))
    return out


def independent_ratios(relative: list[dict], role: str | None = None) -> tuple[int, int]:
    """``(rows, independent)`` over the relative rows with both values (of ``role``, or all): a row's
    modelled / paper is its A row's over its B row's, a difference of two logarithms, so the rows span at
    most (absolute rows they use) - (groups of absolute rows linked by rows) independent ratios (the rank
    of their A - B vectors). Rows without their ``a`` / ``b`` keys count as independent."""
    rs = [r for r in relative if r.get("ratio") is not None and (role is None or r["role"] == role)]
    parent: dict = {}

    def find(x):
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    rank = 0
    for i, r in enumerate(rs):
        a, b = (tuple(r["a"]), tuple(r["b"])) if r.get("a") and r.get("b") else (("row", i, "a"), ("row", i, "b"))
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
            rank += 1
    return len(rs), rank


def absolute_counts(absolute: list[dict]) -> tuple[int, int, int]:
    """(predictions within [0.5, 2], predictions modelled, calibration rows)."""
    pred = [r for r in absolute if r["role"] == "prediction" and r["ratio"] is not None]
    return (sum(0.5 <= r["ratio"] <= 2.0 for r in pred), len(pred),
            sum(r["role"].startswith("calibration") for r in absolute))


def count_lines(absolute: list[dict], relative: list[dict]) -> list[str]:
    inside, pred, cal = absolute_counts(absolute)
    rc = relative_counts(relative)
    (a, n), (a1, n1), (_a2, n2) = rc[REL_PREDICTION], rc[REL_ONE_CAL], rc[REL_CAL_ONLY]
    (nr, ki), (np_, kp) = independent_ratios(relative), independent_ratios(relative, REL_PREDICTION)
    return [f"Absolute predictions within [0.5, 2]: {inside} of {pred} ({cal} calibration rows not counted).",
            f"Relative predictions (both rows predicted) with the paper's sign and ratio in [0.5, 2]: {a} of {n}.",
            f"Counted apart: relative rows with one calibration row agree {a1} of {n1}; rows made only of "
            f"calibration rows ({n2}, agreeing by construction or not) are not counted.",
            f"Not independent: a relative row's ratio is its A row's over its B row's, so the {nr} relative rows "
            f"rest on at most {ki} independent ratios, the {np_} counted predictions on at most {kp}."]


NOTES_ABS = ("ratio = modelled / paper. 'calibration on this row': a profile constant was fitted to it (the "
             "profile file names the row), so its ratio is near 1 by construction (1 where one constant was fitted "
             "to that row alone) and is not counted as agreement; 'calibration on ROW': most of its modelled time "
             "is a constant fitted to ROW. Every profile number's source is in warpvol/profiles/*.toml.")
NOTES_REL = ("speed of A over speed of B (>1: A faster), two methods on one card and data set, or one method on two "
             "data sets, table sizes or cards; ratio = modelled / paper; agrees: the paper's sign and ratio within "
             "[0.5, 2]. role: 'prediction' when both absolute rows are predictions (only these are counted), 'one "
             "calibration row' when one was fitted (the ratio is then the predicted row's modelled / paper over the "
             "calibration row's, which is 1 only where the fit is exact; counted apart), 'calibration only' when "
             "both were (not a prediction, not counted).")


def counts_table(absolute: list[dict], relative: list[dict], what: str = "") -> dict:
    inside, pred, cal = absolute_counts(absolute)
    rc = relative_counts(relative)
    rows = [["absolute rows", "prediction", inside, pred, "modelled / paper within [0.5, 2]"],
            ["absolute rows", "calibration on this row", None, cal, "not counted: fitted to the row"]]
    rows += [["relative rows", role, a, n, {REL_PREDICTION: "the count: both rows predicted",
                                            REL_ONE_CAL: "counted apart: the predicted row's ratio over the "
                                                         "calibration row's",
                                            REL_CAL_ONLY: "not counted: both rows fitted"}[role]]
             for role, (a, n) in rc.items()]
    (nr, ki), (np_, kp) = independent_ratios(relative), independent_ratios(relative, REL_PREDICTION)
    return {"title": f"Throughput model: agreement by role{what}",
            "columns": ["rows", "role", "agree", "of", "counted"], "rows": rows,
            "independent": {"relative_rows": nr, "independent_ratios": ki, "prediction_rows": np_,
                            "prediction_independent_ratios": kp},
            "notes": " ".join(count_lines(absolute, relative))}


def to_json(absolute: list[dict], relative: list[dict], skipped: dict, notes_abs: str = NOTES_ABS,
            source: str = "python scripts/validate_model.py --json docs/data/validate_model.json") -> dict:
    if skipped:
        notes_abs += " Skipped: " + "; ".join(f"{k} ({v})" for k, v in skipped.items())

    def tables(absolute, relative, what=""):
        return {"rows": {"title": f"Throughput model: absolute rows{what}",
                         "columns": ["paper", "row", "paper value", "modelled", "ratio", "role", "note"],
                         "rows": [[r["paper"], r["row"], r["paper_value"], r["modelled"], r["ratio"], r["role"],
                                   r["note"]] for r in absolute], "notes": notes_abs,
                         "sensitivity": {r["row"]: r["at"] for r in absolute if r.get("at")}},
                "relative": {"title": f"Throughput model: relative rows (A over B){what}",
                             "columns": ["paper", "row", "card", "data", "paper", "modelled", "ratio", "agrees",
                                         "role", "note"],
                             "rows": [[r["paper"], r["row"], r["card"], r["data"], r["paper_rel"], r["modelled_rel"],
                                       r["ratio"], r["agrees"], r["role"], r["note"]] for r in relative],
                             "notes": f"{NOTES_REL} {' '.join(count_lines(absolute, relative)[1:])}"},
                "counts": counts_table(absolute, relative, what)}

    out = tables(absolute, relative)
    for paper in dict.fromkeys(r["paper"] for r in absolute):  # each paper's page shows its own rows
        slug = paper.split()[0].lower() + paper.split()[-1]
        per = tables([r for r in absolute if r["paper"] == paper], [r for r in relative if r["paper"] == paper],
                     f", {paper}")
        out[f"rows_{slug}"], out[f"relative_{slug}"], out[f"counts_{slug}"] = per["rows"], per["relative"], per["counts"]
    return {"source": source, "tables": out}


def absolute_from(path: str) -> tuple[list[dict], str, str, str]:
    """The absolute rows of an earlier JSON (``to_json``'s form), its absolute-table notes, its source and
    the Espinha view note of its relative rows."""
    with open(path) as f:
        d = json.load(f)
    t = d["tables"]["rows"]
    keys = ("paper", "row", "paper_value", "modelled", "ratio", "role", "note")
    rows = [{**dict(zip(keys, r)), "at": t.get("sensitivity", {}).get(r[1])} for r in t["rows"]]
    view = next((r[-1][r[-1].index("cells walked"):] for r in d["tables"]["relative"]["rows"]
                 if "cells walked" in str(r[-1])), "")
    return rows, t.get("notes", NOTES_ABS), d.get("absolute_source", d.get("source", path)), view
