"""`kanedyn.Study` and `results.json`.

- A study run from Python gives arrays equal to the CSV files the CLI writes for the same study,
  bit for bit, every file and every column (examples/cpva_paper.ron: sweeps, multi-order, linear,
  Campbell, harmonic balance).
- The CLI's results.json validates against docs/results.schema.json (a JSON Schema validator;
  broken documents are refused, so the check is not vacuous), and its numbers equal summary.md's
  tables as the summary prints them.
- The Python result and results.json are the same data.
- A failing analysis is reported and the others kept; bad input raises located errors.
"""

import json
import math
import os
import shutil
import tempfile

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, ROOT, read_csv, same_bits

jsonschema = pytest.importorskip("jsonschema", reason="jsonschema is installed by run-tests.sh")

PAPER = EXAMPLES / "cpva_paper.ron"
SCHEMA = json.loads((ROOT / "docs" / "results.schema.json").read_text())


@pytest.fixture(scope="module")
def paper_from_python():
    """The paper study run from Python without an output folder."""
    return kanedyn.Study.from_file(PAPER).run()


def test_study_arrays_equal_the_cli_csvs(paper_from_python, cli_run):
    out = cli_run(PAPER)
    res = paper_from_python
    assert res.status == "complete" and res.failures == [] and res.files == [] and res.out_dir is None
    csv_files = sorted(p.name for p in out.glob("*.csv"))
    assert sorted(f"{name}.csv" for name in res.tables) == csv_files and len(csv_files) == 14
    cells = 0
    for name, columns in res.tables.items():
        want = read_csv(out / f"{name}.csv")
        assert list(columns) == list(want), name
        for column, values in columns.items():
            # Wall times are not in any CSV, so everything here is deterministic.
            # The CSV writes 0 for -0 (issue 54, item 4): only the sign of zero is forgiven.
            assert same_bits(np.asarray(values) + 0.0, np.asarray(want[column]) + 0.0), f"{name}.csv: {column}"
            cells += len(values)
    assert cells > 40_000  # 49,826 for the paper study
    # Units as the headers name them.
    assert res.units["sweep_40Nm_up"]["amp_1x_rad_s2"] == "rad/s²" and res.units["campbell"]["rpm"] == "rpm"
    assert res.units["figure2_c_p_5e-4"]["accel_per_torque_rad_s2_per_Nm"] == "rad/s² per N·m"
    assert res.units["hbm_40Nm_from_above"]["order"] == "1"
    # The undefined cells (the locked twin's second order has no response) are NaN here.
    assert np.isnan(res.tables["sweep_40Nm_up"]["ratio_2x"]).any()


def validator():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    return jsonschema.Draft202012Validator(SCHEMA)


def test_results_json_validates_against_the_schema(cli_run):
    doc = json.loads((cli_run(PAPER) / "results.json").read_text())
    v = validator()
    errors = [f"{e.json_path}: {e.message}" for e in v.iter_errors(doc)]
    assert errors == []
    assert [a["kind"] for a in doc["analyses"]] == ["OrderSweep", "MultiOrder", "LinearResponse", "Campbell", "HarmonicBalance"]
    # Broken documents are refused: a NaN smuggled in as text, a missing column unit, a sweep
    # result in a Campbell entry, an unknown status, a failed analysis that still has a result.
    broken = []
    d = json.loads(json.dumps(doc))
    d["analyses"][0]["tables"][0]["columns"][2]["values"][5] = "NaN"
    broken.append(d)
    d = json.loads(json.dumps(doc))
    del d["analyses"][1]["tables"][0]["columns"][0]["unit"]
    broken.append(d)
    d = json.loads(json.dumps(doc))
    d["analyses"][3]["result"] = doc["analyses"][0]["result"]
    broken.append(d)
    d = json.loads(json.dumps(doc))
    d["status"] = "fine"
    broken.append(d)
    d = json.loads(json.dumps(doc))
    d["analyses"][2]["status"] = "failed"
    broken.append(d)
    for k, d in enumerate(broken):
        assert not v.is_valid(d), f"broken document {k} passed"


def rust_exp(x, digits):
    """Rust's `{:.Ne}`: no sign or padding on the exponent."""
    mantissa, exponent = f"{x:.{digits}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def num(x, sig):
    """`plot::num`, the summary's and the figures' number form: `sig` significant digits,
    trailing zeros dropped, exponent form (no sign or padding) only below 1e-3 or from 1e5 on."""
    x = float(f"{x:.{sig - 1}e}")
    a = abs(x)
    if x == 0:
        return "0"
    if not 1e-3 <= a < 1e5:
        mantissa, exponent = f"{x:.{sig - 1}e}".split("e")
        if "." in mantissa:
            mantissa = mantissa.rstrip("0").rstrip(".")
        return f"{mantissa}e{int(exponent)}"
    decimals = min(max(sig - 1 - math.floor(math.log10(a)), 0), 12)
    text = f"{x:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def rust_display(x):
    """Rust's `{}` of an f64 (no trailing `.0`)."""
    return str(int(x)) if float(x).is_integer() else repr(x)


def tables_of(summary, heading):
    """The Markdown tables of the section whose heading starts with `heading`, as rows of cells."""
    section = next(s for s in summary.split("\n## ") if s.startswith(heading))
    tables, current = [], []
    for line in section.splitlines() + [""]:
        if line.startswith("|"):
            current.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif current:
            tables.append([r for r in current[1:] if not set("".join(r)) <= set("-")])  # header, rule dropped
            current = []
    return section, tables


def cell(x, digits):
    return "undefined" if x is None else f"{x:.{digits}f}"


def intervals(iv):
    return "none" if not iv else ", ".join(f"{a:.3f}–{b:.3f}" for a, b in iv)


def test_results_json_numbers_equal_the_summary(cli_run):
    out = cli_run(PAPER)
    doc = json.loads((out / "results.json").read_text())
    summary = (out / "summary.md").read_text()
    by_name = {a["name"]: a for a in doc["analyses"]}
    compared = 0

    # Order sweep: one row per run.
    sweep = by_name["sweep"]
    # The first table is the runs'; the elements' table follows.
    _, [rows, *_] = tables_of(summary, "Order sweep `sweep`")
    assert len(rows) == len(sweep["result"]["runs"]) == 6
    for row, run, f in zip(rows, sweep["result"]["runs"], sweep["findings"]["runs"]):
        n, a = f["main_order_minimum"]
        s = run["sim"]["stats"]
        assert row == [
            f["label"],
            f"{run['max_relative_angle']:.4f}",
            f"{n:.4f}",
            f"{a:.4f}",
            intervals(f["second_over_main"]),
            str(f["rhs_evals"]),
            f"{s['accepted']} ({s['rejected']})",
            f"{run['sim']['wall_s']:.3f}",
        ]
        assert f["rhs_evals"] == s["rhs_evals"] + s["sample_rhs_evals"]
        compared += 1
    for amp in sweep["findings"]["amplitudes"]:
        line = f"- T_n = {rust_display(amp['amplitude'])} N·m: up and down main-order traces differ by more than 1.5× at n = {intervals(amp['up_down_differ'])}"
        assert line in summary
        compared += 1

    # Multi-order: amplitudes, ratios, linear amplitudes and ratios, steadiness.
    multi = by_name["multi_order"]
    _, tables = tables_of(summary, "Multi-order response `multi_order`")
    for row, sp, f in zip(tables[0], multi["result"]["speeds"], multi["findings"]["speeds"]):
        expect = [rust_display(sp["rpm"])]
        for k in range(2):
            expect += [
                cell(sp["response"]["amplitudes"][k], 4),
                cell(sp["locked"]["amplitudes"][k], 4),
                cell(f["ratio"][k], 3),
                cell(sp["linear"][k], 4),
                cell(f["linear_ratio"][k], 3),
            ]
        r = sp["response"]
        expect += [
            f"{rust_exp(r['change'], 1)} (locked {rust_exp(sp['locked']['change'], 1)})",
            f"{r['max_relative_angle']:.4f}",
            f"{r['time_s']:.0f}",
            rust_exp(r["speed_correction"], 2),
        ]
        assert row == expect
        compared += 1
    # The linear elements' peaks over speed: one row per reported joint, its largest torque as
    # results.json's linear elements have it.
    joints = [e["joint"] for e in multi["result"]["speeds"][0]["linear_elements"]]
    assert [row[0] for row in tables[1]] == [f"`{j}`" for j in joints]
    for row, j in zip(tables[1], range(len(joints))):
        peaks = [(sp["linear_elements"][j]["torque"]["peak"], sp["rpm"]) for sp in multi["result"]["speeds"]]
        top, rpm = max(peaks)
        assert row[1] == rust_exp(top, 5) and row[2] == rust_display(rpm)
        compared += 1
    # The elements' table: one row per speed and reported joint, the peak and the range (mean
    # [min, max], largest |q|) as results.json has them.
    element_rows = [(sp, e) for sp in multi["result"]["speeds"] for e in sp["response"]["elements"]]
    assert len(tables[2]) == len(element_rows) > 0
    for row, (sp, e) in zip(tables[2], element_rows):
        assert row[0] == rust_display(sp["rpm"]) and row[1] == f"`{e['joint']}`"
        assert row[3] == num(e["peak"], 5)
        assert row[4] == f"{num(e['mean'], 5)} [{num(e['min'], 5)}, {num(e['max'], 5)}]"
        assert row[5] == num(e["max_abs"], 5)
        compared += 1
    for row, sp, f in zip(tables[3], multi["result"]["speeds"], multi["findings"]["speeds"]):
        assert row[2] == f"{rust_exp(f['hbm_match'], 2)} relative"
        fold = sp["hbm_lower_fold"]
        assert (fold is None) == (row[3] == "reaches the full torques")
        if fold is not None:
            assert row[3].startswith(f"ends at {fold:.4f} × the torques")
        compared += 1

    # Linear response: n_t, and per variant the extremes, the crossing and the asymptote.
    lin = by_name["figure2"]
    section, tables = tables_of(summary, "Linear frequency response `figure2`")
    nt = lin["result"]["n_t"]
    assert f"- tuning order n_t (spin held, undamped) of `pivot` = {nt:.10f}" in section
    for o, label in lin["result"]["free_orders"]:
        assert f"- free undamped eigen-order {o:.10f} (mode `{label}`)" in section
    for row, v, f in zip(tables[1], lin["result"]["variants"], lin["findings"]["variants"]):
        assert row == [
            v["label"],
            f"{v['min'][1]:.5f}", f"{v['min'][0]:.5f}", f"{f['min_order_over_nt']:.6f}",
            f"{v['max'][1]:.4f}", f"{v['max'][0]:.5f}", f"{f['max_order_over_nt']:.6f}",
            f"{v['crossing']:.8f}", f"{f['crossing_over_nt']:.8f}",
            f"{v['asymptote']:.8f}",
        ]
        compared += 1

    # Campbell: per mode, the frequencies at both ends and the order there.
    camp = by_name["campbell"]
    _, [rows, *_] = tables_of(summary, "Campbell diagram `campbell`")
    for k, (row, f) in enumerate(zip(rows, camp["findings"]["modes"])):
        assert row == [
            str(k + 1), f["label"], f"{f['frequency_at_min_rpm_hz']:.4f}", f"{f['frequency_at_max_rpm_hz']:.4f}",
            f"{f['order_at_max_rpm']:.6f}", "yes" if f["order_line"] else "no",
        ]
        compared += 1

    # Harmonic balance: per branch the counts, route, folds, bifurcations, jumps and time.
    hbm = by_name["hbm"]
    _, [rows] = tables_of(summary, "Harmonic balance `hbm`")
    for row, b, f in zip(rows, hbm["result"]["branches"], hbm["findings"]["branches"]):
        up, down = f["sweep_jumps"]
        assert row == [
            rust_display(b["amplitude"]),
            rust_display(b["from"]),
            str(f["points"]),
            b["route_detail"],
            f"{f['stable']} / {f['unstable']}",
            ", ".join(f"{x:.5f}" for x in b["folds"]) or "none",
            ", ".join(f"{k} at {o:.5f}" for o, k in b["bifurcations"]) or "none",
            f"{'none' if up is None else f'{up:.4f}'}, {'none' if down is None else f'{down:.4f}'}",
            f"{1e3 * b['wall_s']:.1f}",
            f"{1e3 * b['wall_s'] / max(f['points'], 1):.3f}",
            b["end"],
        ]
        assert f["points"] == len(b["order"]) == f["stable"] + f["unstable"]
        compared += 1
    # Sweep runs and findings, multi-order rows, linear element peaks, element rows, HBM rows,
    # linear, Campbell, branches.
    assert compared == 6 + 2 + 7 + 1 + 7 + 7 + 3 + 1 + 4


def test_the_python_result_is_the_data_of_results_json(tmp_path):
    study = kanedyn.Study.from_file(EXAMPLES / "cpva_linear.ron")
    assert study.name == "cpva_linear" and study.analyses == [("LinearResponse", "figure2"), ("Campbell", "campbell")]
    assert study.mechanism.ndof == 2
    res = study.run(out=tmp_path)
    folder = tmp_path / "cpva_linear"
    assert res.out_dir == str(folder) and str(folder / "results.json") in res.files
    text = (folder / "results.json").read_text()
    assert res.to_json() == text
    assert res.data == json.loads(text)
    assert res.summary == (folder / "summary.md").read_text()
    validator().validate(res.data)
    # The tables are the document's tables, null as NaN.
    for a in res.data["analyses"]:
        for t in a["tables"]:
            for c in t["columns"]:
                values = np.array([math.nan if v is None else v for v in c["values"]], dtype=float)
                assert same_bits(res.tables[t["name"]][c["name"]], values)
                assert res.units[t["name"]][c["name"]] == c["unit"]
    assert res.analysis("campbell")["result"]["rpm"] == list(res.tables["campbell"]["rpm"])
    with pytest.raises(KeyError, match="no analysis `nope`"):
        res.analysis("nope")


def test_a_run_without_out_leaves_nothing_behind():
    before = {p for p in os.listdir(tempfile.gettempdir()) if p.startswith("kanedyn-study-")}
    res = kanedyn.Study.from_file(EXAMPLES / "cpva_linear.ron").run()
    after = {p for p in os.listdir(tempfile.gettempdir()) if p.startswith("kanedyn-study-")}
    assert after <= before and res.status == "complete" and len(res.tables) == 5


def test_a_failing_analysis_is_reported_and_the_others_kept(tmp_path):
    shutil.copy(EXAMPLES / "cpva.ron", tmp_path / "cpva.ron")
    (tmp_path / "iso.ron").write_text(
        """Study(
    name: "iso",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        LinearResponse(name: "before", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
        HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                        harmonics: 1, multiples: [1.0]),
        Campbell(name: "after", rpm_min: 0.0, rpm_max: 2000.0, points: 5),
    ],
)
"""
    )
    res = kanedyn.Study.from_file(tmp_path / "iso.ron").run()
    assert res.status == "partial" and res.failures
    assert all(f.startswith("HarmonicBalance `diverges` (") and "iso.ron:7:9" in f for f in res.failures)
    assert "Status: partial results" in res.summary
    status = {a["name"]: a["status"] for a in res.data["analyses"]}
    assert status == {"before": "complete", "diverges": "partial", "after": "complete"}
    assert {"before_as_built", "after"} <= set(res.tables)
    assert len(res.tables["after"]["rpm"]) == 5
    validator().validate(res.data)


def test_study_errors_are_located(tmp_path):
    with pytest.raises(kanedyn.ReadError) as e:
        kanedyn.Study.from_file(tmp_path / "none.ron")
    assert "none.ron" in str(e.value)
    with pytest.raises(kanedyn.ArgumentError, match="max_cpu_hours must be a finite, positive number, got -1"):
        kanedyn.Study.from_file(PAPER, max_cpu_hours=-1.0)
    # The paper study needs more than a second of CPU: refused at load, naming the field.
    with pytest.raises(kanedyn.InputError) as e:
        kanedyn.Study.from_file(PAPER, max_cpu_hours=1e-6)
    assert e.value.field.startswith("analyses[") and "--max-cpu-hours" in str(e.value)
    (tmp_path / "bad.ron").write_text('Study(name: "b", mechanism: "none.ron", analyses: [])')
    with pytest.raises(kanedyn.InputError) as e:
        kanedyn.Study.from_file(tmp_path / "bad.ron")
    assert (e.value.line, e.value.field) == (1, "mechanism") and "none.ron" in str(e.value)
