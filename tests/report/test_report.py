"""The report layer: HTML and PDF from a hand-built StudyResult (no fitting involved)."""

from __future__ import annotations

import io
import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from matid.io.results import stiffness_json
from matid.model.results import Estimate, Failure, InputFile, Series, StudyResult
from matid.model.results import TestFit as Fit
from matid.model.study import Specimen, Study
from matid.model.study import Test as LabTest
from matid.report import render_report
from matid.report.bend import TITLES, outline
from matid.report.content import build_report
from matid.report.figures import axis_unit, png_bytes
from matid.report.formats import format_value
from matid.report.html import render_html
from matid.report.quantities import Nested, info_cell
from matid.report.summary import merged_names, scale_of, value_cells

pypdf = pytest.importorskip("pypdf")

STUDY_NAME = "Pebax 40D tube, lot 2611"
ROOT = Path("/lab/study")
NOTE = "<script>alert('x')</script> re-clamped after run 2"
BENDING_WARNING = "bending data scatter larger than expected"


def _sha(name: str) -> str:
    return (name.encode().hex() * 8)[:64]


def _input(test: LabTest, columns: dict[str, str]) -> InputFile:
    meta = {"machine": "Zwick Z0.5", "operator": "A. Engineer", "date": "2024-11-26"}
    return InputFile(test.file, _sha(test.file.name), meta, columns, n_rows=400)


def _shape_figure() -> Figure:
    """Deformed shape at the largest deflection."""
    fig = Figure(figsize=(5, 3))
    ax = fig.add_subplot()
    s = np.linspace(0, 30, 50)
    ax.plot(s, -0.001 * s**2)
    ax.set_xlabel("s [mm]")
    return fig


def _extension(specimen: str, tests: list[LabTest], rng: np.random.Generator) -> Fit:
    k1, k2, tau = 120.0, 45.0, 8.0
    series = []
    for i, test in enumerate(tests):
        t = np.linspace(0, 60, 600)
        strain = np.minimum(t / 10, 1.0) * 0.02 * (1 + 0.25 * i)
        relax = np.where(t < 10, t / 10, np.exp(-(t - 10) / tau))
        model = k1 * strain + k2 * strain.max() * relax
        series.append(Series(test.file.stem, t, model + rng.normal(0, 0.02, t.size), model))
    estimates = (
        Estimate("E_e", k1, 0.8, (k1 - 1.6, k1 + 1.6), 1800, "sls"),
        Estimate("sls_k1", k1, 0.8, (k1 - 1.6, k1 + 1.6), 1800, "sls"),
        Estimate("sls_k2", k2, 1.1, (k2 - 2.2, k2 + 2.2), 1800, "sls"),
        Estimate("sls_eta", k2 * tau, 12.0, (k2 * tau - 24, k2 * tau + 24), 1800, "sls"),
    )
    info = {
        "noise_sd": 0.02,
        "runs": [t.file.name for t in tests],
        "optimizer": {"nfev": 41, "success": True},
    }
    return Fit(
        "extension",
        specimen,
        tuple(tests),
        estimates,
        tuple(series),
        "time [s]",
        "force [N]",
        correlation={"sls_k2|sls_eta": -0.62, "sls_k1|sls_k2": 0.97},
        info=info,
    )


def _bending(tests: list[LabTest], rng: np.random.Generator) -> Fit:
    e_b = 6.5e-5
    series = []
    for test in tests:
        x = np.linspace(0, 0.8, 30) / test.params["free_length"]
        model = e_b * x
        series.append(
            Series(
                f"L = {test.params['free_length'] * 1e3:.0f} mm",
                x,
                model * (1 + rng.normal(0, 0.02, x.size)),
                model,
            )
        )
    est = Estimate("E_b", e_b, 1e-7, (6.48e-5, 6.52e-5), 90, "linear", warnings=(BENDING_WARNING,))
    return Fit(
        "magnetic_bending",
        "T1",
        tuple(tests),
        (est,),
        tuple(series),
        "tip angle / free length [rad/m]",
        "torque [N m]",
    )


def _torsion(tests: list[LabTest], *, extras: list | None = None) -> Fit:
    e_t = 4.4e-5
    x = np.linspace(0, 60, 80)
    y = e_t * x - 2e-9 * np.maximum(x - 35, 0) ** 3
    used = x <= 35
    info: dict[str, object] = {"fit_window": {"x_min": 0.0, "x_max": 35.0}, "linear_range_rel_dev": 0.01}
    if extras is not None:
        info["figures"] = extras
    est = Estimate("E_t", e_t, 2e-7, (4.36e-5, 4.44e-5), int(used.sum()), "linear")
    return Fit(
        "torsion",
        "T1",
        tuple(tests),
        (est,),
        (Series("torsion T1", x, y, e_t * x, used),),
        "twist angle / length [rad/m]",
        "torque [N m]",
        warnings=("nonlinear above 35 rad/m: points excluded from the fit",),
        info=info,
    )


def make_result(*, kinds: tuple[str, ...] | None = None, seed: int = 1) -> StudyResult:
    """A synthetic study: 2 specimens, every test kind, a failure, a pending test, extra figures."""
    rng = np.random.default_rng(seed)
    specimens = (Specimen("T1", 2.4e-3, 1.6e-3), Specimen("T2", 2.4e-3, 1.6e-3))
    ext = [
        LabTest("extension", s, ROOT / f"extension_{s}_r{i}.csv", {"gauge_length": 0.05}, index=i)
        for s in ("T1", "T2")
        for i in (1, 2, 3)
    ]
    bend = [
        LabTest(
            "magnetic_bending",
            "T1",
            ROOT / f"bending_T1_L{n}.csv",
            {"free_length": n * 1e-3, "magnet_moment": 0.0125},
            index=10 + n,
        )
        for n in (20, 30, 40)
    ]
    bend_t2 = LabTest("magnetic_bending", "T2", ROOT / "bending_T2_L30.csv", {"free_length": 0.03}, index=50)
    tors = [
        LabTest("torsion", "T1", ROOT / "torsion_T1_L60.csv", {"length": 0.06}, index=60),
        LabTest(
            "torsion",
            "T1",
            ROOT / "torsion_T1_L60_bad.csv",
            {"length": 0.06},
            exclude=True,
            note=NOTE,
            index=61,
        ),
    ]
    tpb = LabTest(
        "three_point_bend",
        "T1",
        ROOT / "3pb_T1_S10.csv",
        {"span": 0.01, "specimen_length": 0.03, "support_radius": 0.002, "nose_radius": 0.002},
        index=70,
    )
    tests = [*ext, *bend, bend_t2, *tors, tpb]
    if kinds is not None:
        tests = [t for t in tests if t.kind in kinds]
    study = Study(STUDY_NAME, ROOT / "study.toml", specimens, tuple(tests), temperature="37 degC")
    extras = [
        ("Sensitivity of the torque to E_t", png_bytes(_shape_figure(), dpi=60, tight=True)),
        _shape_figure,
    ]
    fits = [
        _extension("T1", ext[:3], rng),
        _extension("T2", ext[3:], rng),
        _bending(bend, rng),
        _torsion(tors[:1], extras=extras),
    ]
    fits = [f for f in fits if kinds is None or f.kind in kinds]
    failures = [Failure("magnetic_bending", "T2", "torque column is constant: no slope to fit")]
    pending = [Failure("three_point_bend", "T1", "the E_s fitter is not available in this version")]
    units = {
        "extension": {"time": "s", "force": "N", "elongation": "mm"},
        "magnetic_bending": {"tip_angle": "deg", "field": "mT", "field_angle": "deg"},
        "torsion": {"twist_angle": "deg", "torque": "mN mm"},
        "three_point_bend": {"deflection": "mm", "force": "N"},
    }
    return StudyResult(
        study=study,
        inputs=tuple(_input(t, units[t.kind]) for t in tests),
        fits=tuple(fits),
        failures=tuple(f for f in failures if kinds is None or f.kind in kinds),
        pending=tuple(p for p in pending if kinds is None or p.kind in kinds),
        started="2024-11-26T14:03:12+01:00",
        runtime_s=4.2,
        versions={"matid": "0.1.0", "numpy": np.__version__, "scipy": "1.14.1"},
    )


@pytest.fixture(scope="module")
def full() -> tuple[StudyResult, dict[str, bytes]]:
    result = make_result()
    return result, render_report(result)


@pytest.fixture(scope="module")
def html(full) -> str:
    return full[1]["report.html"].decode("utf-8")


@pytest.fixture(scope="module")
def pdf(full) -> pypdf.PdfReader:
    return pypdf.PdfReader(io.BytesIO(full[1]["report.pdf"]))


def test_html_has_one_image_per_plot(full, html):
    result = full[0]
    plots = sum(1 for f in result.fits if f.series)
    extras = sum(len(f.info.get("figures", [])) for f in result.fits)
    assert plots == 4 and extras == 2
    assert html.count("<img") == plots + extras
    assert html.count("<figcaption>") == plots + extras
    assert "<script" not in html and "http://" not in html and "https://" not in html
    for img in re.findall(r"<img [^>]*>", html):
        assert 'src="data:image/png;base64,' in img and 'alt="' in img


def test_html_shows_values_warnings_failures_and_pending(full, html):
    doc = stiffness_json(full[0])
    for params in doc["specimens"].values():
        for item in params.values():
            value, stderr, _, low, high, unit = value_cells(item)
            assert f">{value}<" in html and f">{stderr}<" in html and f">{unit}<" in html
            assert f">{low} to {high}<" in html
    report = build_report(full[0], "SI")
    count = len(report.notes) + len(report.failures)
    assert BENDING_WARNING in html and "⚠ [1]" in html and f"<h2>{count} warnings</h2>" in html
    assert "No warnings" not in html
    assert "could not be fitted" in html and "torque column is constant" in html
    assert "E_s: not yet fitted" in html and "E_s fitter is not available" in html
    assert "excluded from fit" in html or "excluded from the fit" in html
    assert "sls_k1" in html and "+0.970" in html  # correlation table
    assert "fit window" in html and ">35 rad/m<" not in html and ">35<" in html  # info, formatted
    assert _sha("torsion_T1_L60.csv")[:12] in html and _sha("torsion_T1_L60.csv") in html
    assert "Zwick Z0.5" in html and "mN mm" in html and "exclude = true" in html


def test_html_sections_only_for_kinds_present(html):
    for kind in ("extension", "magnetic_bending", "torsion", "three_point_bend"):
        assert f'<section id="{kind}">' in html
    only = render_report(make_result(kinds=("torsion",)))["report.html"].decode()
    assert '<section id="torsion">' in only
    for kind in ("extension", "magnetic_bending", "three_point_bend"):
        assert f'id="{kind}"' not in only and f'href="#{kind}"' not in only
    assert only.count("<img") == 3


def test_html_escapes_user_text(html):
    assert "<script>alert" not in html
    assert "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;" in html


def test_pdf_opens_and_has_the_content(full, pdf):
    data = full[1]["report.pdf"]
    assert data.startswith(b"%PDF")
    sections = 4
    assert len(pdf.pages) >= sections + 1 + 1  # title, sections, provenance
    text = "\n".join(page.extract_text() for page in pdf.pages)
    assert STUDY_NAME in text
    assert "could not be fitted" in text and "E_s: not yet fitted" in text
    assert "Magnetic bending" in text and "Provenance" in text
    assert _sha("torsion_T1_L60.csv") in text
    assert pdf.metadata.title.startswith(STUDY_NAME)
    assert pdf.metadata.creator == "matid 0.1.0"


def test_cgs_report_shows_dyn():
    result = make_result(kinds=("torsion", "extension"))
    out = render_report(result, units="cgs")
    html = out["report.html"].decode()
    assert "dyn cm^2" in html and "dyn s" in html and "N m^2" not in html
    value = stiffness_json(result, "cgs")["specimens"]["T1"]["E_t"]["value"]
    assert f"{value:.5g}" in html
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(io.BytesIO(out["report.pdf"])).pages)
    assert "dyn" in text


def test_unknown_unit_system_is_refused():
    with pytest.raises(ValueError, match="units must be one of"):
        render_report(make_result(kinds=("torsion",)), units="imperial")


def test_broken_extra_figure_is_reported_not_raised():
    def broken() -> Figure:
        raise RuntimeError("no solver output")

    result = make_result(kinds=("torsion",))
    fit = _torsion(list(result.study.tests[:1]), extras=[broken, ("not a png", b"GIF89a")])
    result = StudyResult(result.study, result.inputs, (fit,))
    html = render_report(result)["report.html"].decode()
    assert html.count("could not be drawn") == 2 and "no solver output" in html


def test_axis_units_convert_for_cgs():
    assert axis_unit("torque [N m]", "cgs").label == "torque [dyn cm]"
    assert axis_unit("torque [N m]", "cgs").factor == 1e7
    assert axis_unit("force [N]", "cgs").factor == 1e5
    assert axis_unit("tip angle / free length [rad/m]", "cgs").label.endswith("[rad/cm]")
    assert axis_unit("time [s]", "cgs").kept_si is None
    assert axis_unit("field [A/m]", "cgs").kept_si == "A/m"
    assert axis_unit("torque [N m]", "SI").factor == 1.0


def test_info_values_are_formatted_readably():
    assert format_value(0.123456789) == "0.12346"
    assert format_value({"x_min": 0.0, "x_max": 35.0}) == "x_min = 0; x_max = 35"
    assert format_value(np.arange(20.0)).endswith("(20 values)")
    assert format_value([1, 2.5, "a"]) == "[1, 2.5, a]"
    assert format_value(np.float64(2.0)) == "2"


def test_awkward_text_and_partial_fits_render():
    """Dollars (mathtext in matplotlib), markup, a fit without a model curve, a fixed value."""
    base = make_result(kinds=("torsion",))
    test = base.study.tests[0]
    x = np.linspace(0.0, 1.0, 50)
    fit = Fit(
        "torsion",
        "T1",
        (test,),
        (Estimate("E_t", 4e-5, None, None, 50, "linear"),),
        (Series("cost $5 and $6", x, 2 * x),),
        "twist [rad]",
        "torque [N m]",
        info={"nested": {"a": [1, 2, {"b": 3.0}]}},
    )
    fixed = (Estimate("E_s", 21.0, None, None, 0, "fixed", extra={"specimen": "T1"}),)
    study = Study("Tube $A$ & <b>B</b>", base.study.source, base.study.specimens, (test,))
    out = render_report(StudyResult(study, (), (fit,), fixed=fixed))
    html = out["report.html"].decode()
    assert "Tube $A$ &amp; &lt;b&gt;B&lt;/b&gt;" in html and "<b>B" not in html
    assert "fixed" in html and "1, 2, b 3" in html and "not read" in html and "{b" not in html
    assert html.count("<img") == 1 and "Residuals" not in html
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(io.BytesIO(out["report.pdf"])).pages)
    assert "Tube $A$ & <b>B</b>" in text


def test_empty_result_renders():
    study = Study("nothing yet", ROOT / "study.toml", (Specimen("T1", 2e-3),), ())
    out = render_report(StudyResult(study, (), ()))
    html = out["report.html"].decode()
    assert "No warnings" in html and '<section id="torsion">' not in html and "<img" not in html
    assert len(pypdf.PdfReader(io.BytesIO(out["report.pdf"])).pages) == 2  # title, provenance


# -- three-point bend: figures drawn from info["plot_data"] ----------------------------------

FE = {"element": "P2", "elements": 32, "discretization_error": 3e-7, "runtime_s": 0.9, "rod_solves": 11}


def _bend_curve(test: LabTest, span: float, rng: np.random.Generator) -> dict:
    """One span of plot_data as the E_s fitter leaves it (shapes in SI, z along the span, x up)."""
    R, r, d_max = 1.2e-3, 2e-3, 1e-3
    d = np.linspace(0.0, d_max, 25)
    timoshenko = 2.3e3 * d * (0.01 / span) ** 2
    model = timoshenko * (1 + 0.25 * d / d_max)
    z = np.linspace(-0.015, 0.015, 61)
    x = np.where(np.abs(z) < span / 2, -d_max * (1 - (2 * z / span) ** 2), 0.2 * (np.abs(z) - span / 2))
    shape = {
        "z": z,
        "x": x,
        "outer_radius": R,
        "deflection": d_max,
        "supports": [((side * span / 2, -(R + r)), r) for side in (-1, 1)],
        "nose": ((0.0, R + r - d_max), r),
        "support_contact_s": 0.45 * span,
    }
    F = model + rng.normal(0, 0.01, d.size)
    return {"label": test.file.name, "span": span, "d": d, "F": F, "model": model,
            "timoshenko": timoshenko, "plus10": model * 1.03, "shape": shape}  # fmt: skip


def _bend_setup(span: float) -> dict[str, float]:
    return {"span": span, "specimen_length": 0.03, "support_radius": 0.002, "nose_radius": 0.002}


def bend_result(*, plot_data: object = None) -> StudyResult:
    """A study whose only fit is a three-point bend on two spans, with plot_data and FE figures."""
    rng = np.random.default_rng(3)
    tests = [
        LabTest("three_point_bend", "T1", ROOT / f"3pb_T1_S{n}.csv", _bend_setup(n * 1e-3), index=70 + n)
        for n in (10, 14)
    ]
    curves = [_bend_curve(t, t.params["span"], rng) for t in tests]
    series = tuple(Series(c["label"], c["d"], c["F"], c["model"]) for c in curves)
    held = {"E_b": {"dlogEs_dlogp": -1.9, "contribution": 0.0042}}
    info = {
        "noise_N": 0.01,
        "sensitivity_to_noise": 4.2,
        "held_stiffness_propagation": held,
        "fe": FE,
        "plot_data": {"curves": curves, "noise_N": 0.01} if plot_data is None else plot_data,
    }
    est = Estimate("E_s", 21.1, 0.1, (20.9, 21.3), 50, "cosserat-fe", extra={"fe": FE})
    fit = Fit(
        "three_point_bend", "T1", tuple(tests), (est,), series, "deflection [m]", "force [N]", info=info
    )
    study = Study(STUDY_NAME, ROOT / "study.toml", (Specimen("T1", 2.4e-3, 1.6e-3),), tuple(tests))
    return StudyResult(study, (), (fit,))


@pytest.fixture(scope="module")
def bend_out() -> dict[str, bytes]:
    return render_report(bend_result())


def test_bend_fit_renders_its_figures(bend_out):
    html = bend_out["report.html"].decode()
    assert html.count("<img") == 1 + len(TITLES)  # the fit plot, then force, sensitivity, shape
    for title in TITLES:
        assert f"<strong>{title}.</strong>" in html
    assert "Timoshenko" in html and "σ = 10 mN" in html and "RMS force change / noise = 4.2" in html
    assert "plot_data" not in html and "plot data" not in html and "curves" not in html
    fe = "FE mesh and solver for E_s: 32 P2 elements, discretisation error 3e-07 of E_s (relative)"
    assert html.count(fe) == 1  # under the parameters; not repeated among the info items
    assert "11 rod solves, run time 0.9 s" in html
    assert "E_b: d ln E_s / d ln E_b = -1.9, adds ±0.42 % to E_s" in html
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(io.BytesIO(bend_out["report.pdf"])).pages)
    for title in (*TITLES, "FE mesh and solver for E_s"):  # panel texts are in the shared PNGs
        assert title in text
    assert "plot_data" not in text


def test_bend_figures_in_cgs_show_dyn():
    html = render_html(build_report(bend_result(), "cgs")).decode()
    assert "force in dyn" in html and "σ = 1e+03 dyn" in html


def test_malformed_plot_data_is_reported_not_raised():
    out = render_report(bend_result(plot_data={"curves": [{"d": [0.0, 1e-3], "F": [0.0]}]}))
    html = out["report.html"].decode()
    assert "could not be drawn" in html and "plot_data curve 1 has no model, timoshenko, plus10, span" in html
    assert html.count("<img") == 1  # the fit plot still shows
    assert out["report.pdf"].startswith(b"%PDF")


def test_tube_outline_is_the_radius_off_the_centreline():
    z = np.linspace(-1.0, 1.0, 21)
    upper, lower = outline(z, 0.5 * z, 0.1)
    assert np.allclose(np.hypot(*(upper - lower).T), 0.2)
    assert np.allclose((upper - lower) @ np.array([1.0, 0.5]), 0.0)  # normal to the centreline


def test_demo_report_has_the_bend_figures():
    from matid.app.pipeline import run_study
    from matid.io.study import load_study

    result = run_study(load_study(Path(str(resources.files("matid.example")))))
    bends = [f for f in result.fits if f.kind == "three_point_bend"]
    assert bends and all("plot_data" in f.info for f in bends)
    out = render_report(result)
    html = out["report.html"].decode()
    for title in TITLES:
        assert html.count(f"<strong>{title}.</strong>") == len(bends)
    assert html.count("FE mesh and solver for E_s") == len(bends) and "plot_data" not in html
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(io.BytesIO(out["report.pdf"])).pages)
    assert all(title in text for title in TITLES)


# -- numbers with units, for people ------------------------------------------------------------

AXES = {"x": ("rad/m", 1.0), "y": ("N m", 1.0)}


def test_info_items_get_labels_and_units_in_the_chosen_system():
    assert info_cell("E_b_used", 6.496e-5, "SI", AXES) == ("E_b held in the E_s fit", "6.496e-5 N m^2")
    assert info_cell("E_b_used", 6.496e-5, "cgs", AXES)[1] == "64960 dyn cm^2"
    assert info_cell("noise_N", 0.0072348, "cgs", AXES)[1] == "723.5 dyn"
    label, text = info_cell("force_change_for_10pct_E_s_N (linearised)", 0.0541, "SI", AXES)
    assert label == "RMS force change for E_s + 10 % (linearised)" and text == "0.0541 N"
    assert info_cell("timoshenko_start_N", 24.553, "SI", AXES) == (
        "E_s start value (Timoshenko formula)",
        "24.55 N",
    )
    assert info_cell("free_lengths_m", [0.03, 0.045], "SI", AXES)[1] == "30, 45 mm"
    assert info_cell("shear_share", [0.2697], "SI", AXES)[1] == "26.97 %"
    assert info_cell("index", [], "SI", AXES) == ("index", "none")


def test_unknown_info_keys_are_read_by_their_suffix():
    assert info_cell("intercept_Nm", 2e-6, "SI", AXES) == ("intercept", "2e-6 N m")
    assert info_cell("toe_length_mm", 0.05, "SI", AXES) == ("toe length", "0.05 mm")
    assert info_cell("E_s_torsion", 21.0, "cgs", AXES) == ("E_s_torsion", "2.1e6 dyn")
    assert info_cell("hold_time_s", 45.0, "SI", AXES) == ("hold time", "45 s")
    assert info_cell("method note", "Newey-West", "SI", AXES) == ("method note", "Newey-West")


def test_nested_info_values_become_small_tables():
    slopes = {0.03: {"E_b": 6.5e-5, "stderr": 3.2e-7, "n_points": 17}}
    label, table = info_cell("per_length_slopes", slopes, "SI", AXES)
    assert isinstance(table, Nested) and label == "E_b of each free length alone"
    assert table.header == ("free length [mm]", "E_b [N m^2]", "stderr [N m^2]", "points")
    assert table.rows == (("30", "6.5e-5", "3.2e-7", "17"),)
    _, ranges = info_cell("linear_range", {"a.csv": 52.36}, "SI", AXES)
    assert ranges.header == ("run", "value [rad/m]") and ranges.rows == (("a.csv", "52.36"),)
    levels = [{"elements": 8, "discretization_error": 1.9e-5, "runtime_s": 0.357}]
    _, table = info_cell("levels", levels, "SI", AXES)
    assert table.header[1:] == ("elements", "discretisation error (relative)", "runtime [s]")
    _, prony = info_cell("prony_terms", [{"tau_s": 1.0, "k_N": 30.0}], "cgs", AXES)
    assert prony.header == ("entry", "tau [s]", "k [dyn]") and prony.rows == (("1", "1", "3e6"),)


def test_cgs_details_carry_cgs_units():
    html = render_report(bend_result(), units="cgs")["report.html"].decode()
    details = html[html.index("Fit window and details") :]
    assert "1000 dyn" in details and " N<" not in details and "N m^2" not in details


def test_summary_rows_round_to_the_standard_error():
    assert scale_of(6.496e-5, 1.4e-7) == (-5, 3)
    assert scale_of(119.97, 0.046) == (0, 3)
    assert scale_of(1367.5, 20.0) == (0, 0)
    item = {"value": 6.4960e-5, "stderr": 1.4e-7, "ci95": [6.4673e-5, 6.5247e-5], "unit": "N m^2"}
    assert value_cells(item) == ("6.496", "0.014", "0.22 %", "6.467", "6.525", "×10⁻⁵ N m^2")
    same = {"value": 1.0, "stderr": 0.1, "unit": "N", "n_points": 3, "method": "sls"}
    assert [n for n, _ in merged_names({"E_e": same, "sls_k1": same, "sls_k2": {**same, "value": 2}})] == [
        "E_e = sls_k1",
        "sls_k2",
    ]


def test_small_axes_get_a_prefixed_unit_and_lengths_are_mm():
    assert axis_unit("torque [N m]", "SI", 5e-4).label == "torque [mN m]"
    assert axis_unit("torque [N m]", "SI", 5e-4).factor == 1e3
    assert axis_unit("deflection [m]", "SI", 1e-3).label == "deflection [mm]"
    assert axis_unit("deflection [m]", "cgs", 1e-3).label == "deflection [mm]"
    assert axis_unit("force [N]", "SI", 3.0).label == "force [N]"


def test_extension_holds_get_a_force_against_time_plot():
    base = make_result(kinds=("extension",))
    fit = next(f for f in base.fits if f.kind == "extension")
    t = np.linspace(0.0, 60.0, 120)
    hold = np.where(t < 10, t / 10, 0.6 + 0.4 * np.exp(-(t - 10) / 8))
    runs = [{"label": "ramp-hold run", "time": t, "force": hold + 0.01, "model": hold, "used": t > 0.5}]
    fit = Fit(fit.kind, fit.specimen, fit.tests, fit.estimates, fit.series, fit.x_label, fit.y_label,
              info={**fit.info, "force_time": runs})  # fmt: skip
    html = render_report(StudyResult(base.study, base.inputs, (fit,)))["report.html"].decode()
    assert "<strong>Force against time.</strong>" in html and "force_time" not in html
    broken = Fit(fit.kind, fit.specimen, fit.tests, fit.estimates, fit.series, fit.x_label, fit.y_label,
                 info={"force_time": [{"time": [0.0, 1.0], "force": [1.0]}]})  # fmt: skip
    html = render_report(StudyResult(base.study, base.inputs, (broken,)))["report.html"].decode()
    assert "could not be drawn" in html and "force_time run 1: time, force" in html


def test_bench_page_has_no_json_dump_no_raw_rst_and_scrolling_tables():
    from matid.bench.html import page

    doc = {
        "quick": True,
        "created": "2026-11-23",
        "runtime_s": 1.0,
        "machine": {"cpu": "x"},
        "sections": {
            "stability": {
                "rows": [{"family": "f", "case": "c", "outcome": "ok", "message": "m" * 200}],
                "outcomes": {"ok": 1},
                "outcome_rules": "- ``ok``: converged (:mod:`matid.bench.checks`);\n"
                "- ``wrong``: must\n  not occur.",
            },
            "vs_3d": {
                "rows": [{"model": "3d", "dofs": 10}],
                "converged": {"bend": {"3d": 1.5, "status_3d": "Richardson"}},
                "ratios": {"bend": {"3d": {"dofs": 100.0, "time_s": 2.0}, "lower_bound": False}},
                "section": {"E": 1e7, "nu": 0.45},
                "notes": ["Bend: 3D quarter model."],
                "quick": True,
            },
        },
    }
    html = page(doc, {})
    assert "``" not in html and ":mod:" not in html and "<code>ok</code>" in html and "must not occur" in html
    assert "<pre>" not in html and '{"' not in html and "{'" not in html
    assert "3d dofs" in html and "Bend: 3D quarter model." in html and "Richardson" in html
    assert html.count("<table>") == html.count("<div class='scroll'><table>")


def test_dashed_model_line_and_its_legend_only_past_the_fitted_points():
    from matid.report.figures import _series_outside

    x = np.linspace(0.0, 1.0, 11)
    inner = Series("a", x, x, x, used=np.array([True] * 4 + [False] + [True] * 6))
    tail = Series("b", x, x, x, used=x <= 0.6)
    assert not _series_outside(inner) and _series_outside(tail)
    assert not _series_outside(Series("c", x, x, None, used=x <= 0.6))


def test_fit_blocks_number_their_warnings_once_below_the_parameters(full):
    """A parameter's warning (stiffness.json) is listed once in its block, in full, and the block's
    parameter table refers to it by number; the fit's own warnings come first."""
    report = build_report(full[0], "SI")
    blocks = [b for s in report.sections for b in s.blocks if b.parameters and b.parameters.rows]
    bending = next(b for b in blocks if any(BENDING_WARNING in w for w in b.warnings))
    assert len(bending.warnings) == len(set(bending.warnings))
    assert list(bending.fit.warnings) == list(bending.warnings[: len(bending.fit.warnings)])
    n = bending.warnings.index(BENDING_WARNING) + 1
    row = next(r for r in bending.parameters.rows if r[0] == "E_b")
    assert row[-1] == f"⚠ [{n}]"
    assert all(BENDING_WARNING not in cell for r in bending.parameters.rows for cell in r)
