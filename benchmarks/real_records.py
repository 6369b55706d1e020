"""Real-record benchmark: matid on public lab records other people's machines wrote (issue 28, item 1).

    PYTHONPATH=$PWD python benchmarks/real_records.py [--records DIR] [--only ID ...] [--copy-from-mirror DIR]

For each record of RECORDS the file is expected at DIR/<owner>/<repo>/<path> (default DIR
/work/records; never committed: the files carry no licence). ``--copy-from-mirror`` first
copies each record out of the bare git snapshots the search tool's ``fetch`` left in DIR
(/work/.mirror/<owner>+<repo>/repo) at the record's commit.

Per record: sha256 of the file, a study.toml written in a temporary folder that points at
the unedited file (only the study keys a user would write per docs/guide.md), matid.fit(...)
through the Python API, and the hand value from benchmarks/real_records_hand.py (numpy only).
One line per record, then a markdown table. The rule (issue 28 item 2): within 5 % of the
hand value with status ok and a 95 % interval that covers it ("never ok with an interval that
excludes a hand value"), or status check / not_identifiable with a 95 % interval that covers
the hand value. A record that fails the rule or that matid refuses is reported, not
raised: the script exits 0 when everything ran.

Three-point bend: matid fits E_s with E_b and E_e held. These coupons have no bending test,
so E_b and E_e are [[fixed]] from a nominal modulus (stated per record, not from the data),
and the value compared is the flexural stiffness of matid's fitted curve,
E_b,app = 1 / (1/E_b + 12/(S^2 E_s)), its interval mapped from E_s's (monotone), against
the hand value S^3/48 dF/dd.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import real_records_hand as hand  # noqa: E402

IN = 0.0254


@dataclass
class Record:
    id: str
    repo: str
    commit: str
    path: str
    kind: str  # extension | torsion | three_point_bend | magnetic_bending
    machine: str
    dims: str  # the specimen dimensions used
    source: str  # where they were found
    specimen: dict
    test: dict  # the [[test]] keys besides kind, specimen, file
    hand: callable  # (path) -> (value, stderr, n)
    hand_text: str  # the hand computation in words
    fixed: dict = field(default_factory=dict)  # parameter -> "value unit" ([[fixed]])
    note: str = ""
    also: tuple = ()  # further paths of the same repository the hand value reads (copied alongside)

    @property
    def parameter(self) -> str:
        return {"extension": "E_e", "torsion": "E_t", "three_point_bend": "E_s", "magnetic_bending": "E_b"}[
            self.kind
        ]


VHB = ("Chongran-Zhao/VHB4910_data", "a23efd8c4f8abaa907c4d613db6e74ca6b0321c5")
JK = ("Jkillelea/ASEN3112-Lab-1-Code", "da3317fa76589dafcb0f7f8d209605985cb79e9d")
CB = ("calebbristol/ASEN3112", "94b9e3fb3acabd2278192ea4cf11f64522ae5d43")
OD = ("odykak/Flexural-stress-strain", "b52eb0608383f8f95b46ce15fa93aab565830ea6")  # branch Data
PZ = ("e-dub/pyZiagn", "c831eb6ca7faa8a4c979b7cd5d445d4d80ad4f47")
ES = ("ernestsb/statictesting", "4398b17d8d3aebf78c70cd121d95c7d9dd9d3026")
GJ = ("gerlachjan/eval_TensileTest", "b5b0dde966a3834810a867e72abaa0d36081a0b0")
MC = ("macphersoncole/ASEN-3112-Lab1", "0af3a520129a46f5d84efa2b52e05b5902ec884b")
MC_OTW = "Data/DAQ-G1G2-OTW.txt"
MU = ("pedrodamas0803/mechtest_ufmg", "44731d4696a10535f4d5074063d8670ff364ee2d")  # commit "starting things"
# the fatigue files were removed later (d14d21b): each is read at the commit that added it
PM = "FollowTheProcess/pymechtest"
AH = ("a-hilhorst/Tensile-test-Analysis", "e6836508f491bd8a864db831fe5f0e05c65c9402")  # "bu20240904"
AH_DIR = "imap_versions/other_machine_outputs_examples"
TDA = ("ppieczywek/TDA", "92f6dff0f79cc1c5e403ad62a3c747fa10626621")  # "Create LICENSE"
RB = ("raballito/tensile_test_analyzer", "df39176a0ca99420f7fb6e0975b2aeeb090e9c7b")  # "Correction Readme"
# a copy of Dryad doi:10.5061/dryad.8pk0p2nq8 v8 (Kim et al., Sci. Robot. 7, eabg9907, 2022, data S1)
KIM = ("CraYAnshINcHAN/undergraduate_project", "1bde22078601615d092d2b551f94e0e9a378d3a9")
KIM_DIR = "参考文献/doi_10.5061_dryad.8pk0p2nq8__v8"
PM_COMMIT = {
    "Test2": "4b1908e24ede601db1f278861fa0a4243a35c1a9",  # Merge pull request #23 (fatigue)
    "Test5": "cf1b204bdf49413905887fda3edd265765f4d1a9",  # Add fatigue test data ...
}

VHB_SRC = "README.md l.13-14, 25-26: L0 = 8 cm (lambda = 1 + Delta/L0)"
VHB_COLS = {"time": "时间", "elongation": "位移", "force": "力"}
ASEN_TUBE = {"outer_diameter": "0.75 in", "inner_diameter": "0.625 in"}
ASEN_SRC_JK = "main.m l.4-6 (Re = 3/8 in, t = 1/16 in, extensometer L = 1 in)"
ASEN_SRC_MC = "m/TorsionTesting.m l.10-14 (L = 10 in, t = 1/16 in, D_e = 3/4 in, R_e = 3/8 in)"
ASEN_SRC_CB = (
    "Lab 1/TorqueStrain.m l.31-37 (D_e = 0.75 in, t = 1/16 in, L = 10 in); file line 5 'Length: 10 inches'"
)
# odykak: Stress-strain.py (branch main 773bcad) l.28-31: thickness[], width[] in load order, L = 40.28 mm
OD_SRC = "Stress-strain.py (main) l.28-31: thickness, width per coupon, span L = 40.28 mm"
OD_ASSUMED = (  # not stated by the author
    "specimen_length 60 mm, roller and nose radius 5 mm assumed; [[fixed]] E = 3.5 GPa nominal PLA"
)


def vhb_relax(name: str, strain: float, encoding: str | None = "gbk") -> Record:
    test = {"gauge_length": "80 mm", "columns": VHB_COLS} | ({"encoding": encoding} if encoding else {})
    return Record(
        id=f"vhb-relax-{name}",
        repo=VHB[0],
        commit=VHB[1],
        path=f"single-step-relaxation/original_data/{name}.csv",
        kind="extension",
        machine=f"Chinese UTM export ({encoding or 'UTF-8'} header 时间,位移,力 / (s),(mm),(N))",
        dims=f"L0 80 mm; ramp 20 mm/s to strain {strain:g}, hold",
        source=VHB_SRC,
        specimen={"width": "10 mm", "height": "1 mm"},
        test=test,
        hand=lambda p: hand.relaxation(p, gauge_m=0.08),
        hand_text="mean force / strain over the last 60 s of the hold",
        note="specimen width/height not given (VHB4910 is 1 mm thick): section only labels moduli",
    )


def vhb_cycle(name: str) -> Record:
    return Record(
        id=f"vhb-cycle-{name}",
        repo=VHB[0],
        commit=VHB[1],
        path=f"uniaxial-loading-unloading/original_data/{name}.csv",
        kind="extension",
        machine="Chinese UTM export (GBK)",
        dims="L0 80 mm; load to 40 mm and back",
        source=VHB_SRC,
        specimen={"width": "10 mm", "height": "1 mm"},
        test={"gauge_length": "80 mm", "columns": VHB_COLS, "encoding": "gbk"},
        hand=lambda p: hand.cycle_mean(p, gauge_m=0.08, strain_window=(0.1, 0.4)),
        hand_text="mean of loading and unloading force at common strain, line over strain 0.1-0.4",
    )


def asen_torsion(rid, src, path, *, slit, channel, negate=False, source=None) -> Record:
    """ASEN 3112 Lab 1 (University of Colorado): thin-walled 0.75 in x 1/16 in tube, closed or slit.

    channel 'ext': the extensometer reads the surface shear strain gamma (deg) over 1 in; twist per
    length is gamma/Re (closed) or gamma/t (open), so length = Re or t turns gamma into the twist.
    channel 'angle': the machine's angle over the specimen length, 10 in."""
    repo, commit = src
    jk = repo.startswith("Jkillelea")
    spec = {**ASEN_TUBE, "slit": True} if slit else dict(ASEN_TUBE)
    if jk:
        angle, ext, torque, skip, delim = "Angle", "Shear Strain", "Torque", 3, ","
        cols = {"angle": 2, "ext": 1}
        machine = "torsion frame 'Partner Data Point File' CSV (min, deg, in·lb)"
    else:
        angle, ext, torque, skip, delim = (
            "Torsional Angle",
            "Torsional Epsilon 3550 Torsion",
            "Torsional Torque",
            8,
            "\t",
        )
        cols = {"angle": 1, "ext": 2}
        machine = "MTS TestSuite DAQ (Timed) txt, Epsilon 3550 torsional extensometer"
    if channel == "ext":
        L = 1 / 16 * IN if slit else 3 / 8 * IN
        length = "0.0625 in" if slit else "0.375 in"
        slit_text, to = (", slit", "t") if slit else ("", "Re")
        dims = f"D 0.75 in, t 1/16 in{slit_text}; extensometer gamma -> length = {to}"
    else:
        L, length = 10 * IN, "10 in"
        dims = f"D 0.75 in, t 1/16 in{', slit' if slit else ''}; angle over L = 10 in"
    col = angle if channel == "angle" else ext
    return Record(
        id=rid,
        repo=repo,
        commit=commit,
        path=path,
        kind="torsion",
        machine=machine,
        dims=dims,
        source=source
        or (
            (ASEN_SRC_JK + ("; L = 10 in: " + ASEN_SRC_CB if channel == "angle" else ""))
            if jk
            else ASEN_SRC_CB
        ),
        specimen=spec,
        test={"length": length, "columns": {"twist_angle": col, "torque": torque}}
        | ({"negate": ["twist_angle"]} if negate else {}),
        hand=lambda p: hand.torsion(
            p, skip=skip, delim=delim, angle_col=cols[channel], torque_col=3 if jk else 3, length_m=L
        ),
        hand_text=f"loading rows, torque 10-80 % of its excursion, line T({col}), x L",
    )


def bluehill(name: str, steel: str, *, delim: str, skip: int, header: str) -> Record:
    """UFMG tensile coupons (steel 1016 / 1055), Instron Bluehill CSV export: 'Results Table 1', the
    column row Time, Displacement, Force, Tensile strain (Strain 2), Tensile stress, then units (s),
    (mm), (kN), (mm/mm), (MPa). The strain is the extensometer's, so no gauge length enters E_e."""
    return Record(
        id=f"mu-bluehill-{name}",
        repo=MU[0],
        commit=MU[1],
        path=f"data/{name}.csv",
        kind="extension",
        machine=f"Instron Bluehill CSV export ('Results Table 1', 'Tensile strain (Strain 2)'), {header}",
        dims="none needed: extensometer strain column; A0 23.76 mm^2 (Force/Tensile stress, row 1)",
        source=f"data/{name}.csv l.7: force 0.0{'0508' if name == 'am1' else '0661'} kN / stress "
        f"{'0.21382' if name == 'am1' else '0.27843'} MPa = 23.76 mm^2 (the section Bluehill was given)",
        specimen={"outer_diameter": "5.5 mm"},
        test={
            "gauge_length": "25 mm",  # required by the study schema; unused with a strain column
            "columns": {"time": "Time", "strain": "Tensile strain (Strain 2)", "force": "Force"},
            "encoding": "latin-1",
            "window": {"strain": [0.0002, 0.001]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=skip,
            delim=delim,
            decimal=".",
            elong_col=3,
            force_col=2,
            gauge_m=1.0,
            window_m=(2e-4, 1e-3),
            elong_si=1.0,
            strain_col=True,
            encoding="latin-1",
        ),
        hand_text="extensometer strain 0.0002-0.001 (window also given to matid): line F(strain)",
        note=f"steel {steel}; diameter 5.5 mm only labels the section (pi 5.5^2/4 = 23.76 mm^2, as the file)",
    )


def catman(name: str, window_mm: tuple[float, float]) -> Record:
    """Hot tensile test (about 340 C at the end, 'Pyrometer' column) of HSM700 sheet steel, recorded by
    HBM catmanEasy 5.3 on a QuantumX MX840B (the run's .TSX: 'CATMAN TEST FILE', 'catmanEasy/AP
    version=5.3.1.27', 'Firmware MX840B'); tab-separated ASCII, one header row with [unit]s. The
    elongation is the 'Maytec' high-temperature extensometer. The window is where the force rises
    from about 10 % to 70 % of its peak (before that the grips take up slack at about 100 N)."""
    lo, hi = window_mm
    return Record(
        id=f"gj-catman-{name}",
        repo=GJ[0],
        commit=GJ[1],
        path=f"experminent_data/{name}.ASC",
        kind="extension",
        machine="HBM catmanEasy 5.3 ASCII export (QuantumX MX840B), tab, 'Zeit  1 - Standardmessrate [s]'",
        dims="L0 20 mm, width 9.9 mm, thickness 2 mm",
        source="main.m l.6-9 (l0 = 20, wd = 9.9, t = 2, cs_A = wd*t); main.m l.62: column 2 displacement",
        specimen={"width": "9.9 mm", "height": "2 mm"},
        test={
            "gauge_length": "20 mm",
            "columns": {"time": "Zeit  1 - Standardmessrate", "elongation": "Maytec", "force": "Kraft"},
            "encoding": "latin-1",
            "window": {"elongation": [f"{lo:g} mm", f"{hi:g} mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=1,
            delim="\t",
            decimal=".",
            elong_col=1,
            force_col=2,
            gauge_m=0.02,
            window_m=(lo * 1e-3, hi * 1e-3),
            force_si=1.0,
            encoding="latin-1",
        ),
        hand_text=f"Maytec {lo:g}-{hi:g} mm (window also given to matid): line F(strain)",
        note="hot test (about 340 C): E_e is the hot stiffness; no room-temperature reference",
    )


def zwick(
    name: str, lang: str, cols: dict, spec: tuple[float, float, float], window_mm, order, note=""
) -> Record:
    """Tensile coupons of the IMAP lab (UCLouvain), Zwick testXpert II ASCII export ('.TRA'; the
    repository also holds a byte-identical '.txt' copy of each, which is not used): Latin-1, lines
    '"name",value,"unit"' of the test set-up (thickness, width, section, the gauge length of the
    standard-travel extensometer, speeds), then the quoted channel names ('Standard force',
    'Standard travel', 'Crosshead absolute' or their French 'Force standard', 'Course standard',
    'Traverse absolue') and a units row. The test starts at the preload (100-150 N) with the
    extensometer zeroed there. ``spec`` = (thickness, width, gauge length) in mm from the header;
    ``order`` = (elongation column, force column) for the hand script."""
    t, w, L0 = spec
    lo, hi = window_mm
    el, fc = order
    return Record(
        id=f"ah-zwick-{name.replace(' ', '')}",
        repo=AH[0],
        commit=AH[1],
        path=f"{AH_DIR}/{name}.TRA",
        kind="extension",
        machine=f"Zwick testXpert II ASCII export (.TRA, {lang} channel names, Latin-1, header lines)",
        dims=f"thickness {t:g} mm, width {w:g} mm, L0 {L0:g} mm (standard travel)",
        source=f"the file's own header lines 1-4 ({name}.TRA); the author's import_from_txt.m reads the same "
        "keys (l.51-54) and takes Standard travel as u, Standard force as F (l.67, l.70)",
        specimen={"width": f"{w:g} mm", "height": f"{t:g} mm"},
        test={
            "gauge_length": f"{L0:g} mm",
            "columns": cols,
            "encoding": "latin-1",
            "window": {"elongation": [f"{lo:g} mm", f"{hi:g} mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=12,
            delim=",",
            decimal=".",
            elong_col=el,
            force_col=fc,
            gauge_m=L0 * 1e-3,
            window_m=(lo * 1e-3, hi * 1e-3),
            force_si=1.0,
            encoding="latin-1",
        ),
        hand_text=f"standard travel {lo:g}-{hi:g} mm (window also given to matid): line F(strain)",
        note=note,
    )


def wavematrix(name: str, cycles: str) -> Record:
    """Composite coupon cycled from rest between about 0.3 and 4.5 kN on an Instron 8801 (frame
    8801MTB15319), Instron WaveMatrix 'steps.tracking' CSV export: UTF-8 with BOM, every line ending
    in ',', columns like 'Load(8801MTB15319:SH-19-Load) (kN)' and the unused
    'Total Cycle Count(8801MTB15319 Waveform)'. The strain is the extensometer's ('Strain 1', %), so
    no gauge length enters E_e; the section (45.31 mm^2) is Load / Stress of the file's own columns."""
    return Record(
        id=f"pm-wavematrix-{name}",
        repo=PM,
        commit=PM_COMMIT[name],
        path=f"tests/data/Fatigue/{name}.steps.tracking.csv",
        kind="extension",
        machine="Instron WaveMatrix 'steps.tracking' CSV (Instron 8801), BOM, trailing ','",
        dims=f"none needed: extensometer strain column; A0 45.31 mm^2; {cycles}",
        source="the file's Load (kN) / Stress (MPa) columns: 45.31 mm^2 on every row above 0.5 kN",
        specimen={"width": "10 mm", "height": "4.531 mm"},
        test={
            "gauge_length": "25 mm",  # required by the study schema; unused with a strain column
            "columns": {
                "time": "Total Time",
                "force": "Load(8801MTB15319:SH-19-Load)",
                "strain": "Strain(8801MTB15319:Strain 1)",
            },
        },
        hand=lambda p: hand.load_fraction_line(
            p, skip=1, delim=",", force_col=7, strain_col=8, force_si=1e3, strain_si=1e-2
        ),
        hand_text="every row with force 10-90 % of the peak (loading, holds, unloading): line F(strain)",
        note="width x height only stand for A0 = 45.31 mm^2",
    )


# thickness / width of the odykak coupons, in load order (Stress-strain.py l.28-29)
OD_T = [
    2.93666288,
    2.883306388,
    2.966662919,
    2.963329587,
    2.933329548,
    2.914995712,
    2.966662919,
    2.973329599,
    2.926572111,
    2.893329496,
]
OD_W = [
    11.8633324,
    11.88666573,
    11.73333239,
    11.92666573,
    11.97666574,
    11.92666573,
    11.8533324,
    11.74999716,
    12.03999723,
    12.03999723,
]


def od_bend(index: int, name: str) -> Record:
    t, w, S = OD_T[index - 1], OD_W[index - 1], 40.28e-3
    E = 3.5e9
    inertia, A = w * t**3 / 12 * 1e-12, w * t * 1e-6
    return Record(
        id=f"od-3pb-{name}",
        repo=OD[0],
        commit=OD[1],
        path=f"{name}.dat",
        kind="three_point_bend",
        machine="MTS 793 (MTS793/BTW banner, space separated, compression negative)",
        dims=f"b {w:.3f} mm, d {t:.3f} mm, S 40.28 mm",
        source=OD_SRC + "; " + OD_ASSUMED,
        specimen={"width": f"{w:.4f} mm", "height": f"{t:.4f} mm"},
        test={
            "span": "40.28 mm",
            "specimen_length": "60 mm",
            "support_radius": "5 mm",
            "nose_radius": "5 mm",
            "columns": {"deflection": "Ch 1 Displacement", "force": "Ch 1 Force"},
            "negate": ["deflection", "force"],
        },
        fixed={"E_b": f"{E * inertia:.6g} N m^2", "E_e": f"{E * A:.6g} N"},
        # the author's own window: read_csv(skiprows=270) then rows [0:2500] (l.49, l.210)
        hand=lambda p: hand.bend(p, skip=8, rows=(262, 2762), span_m=S),
        hand_text="author's window (file lines 271-2770, Stress-strain.py l.49, l.210): line F(d), x S^3/48",
    )


def kim(mode: str, column: str, psi: float) -> Record:
    """A magnetic soft continuum guidewire bent by a permanent magnet (Kim et al. 2022, Fig. 3C):
    its tip angle at 13 distances d from the magnet, the field angle psi = +-90 deg."""
    return Record(
        id=f"kim-{mode}-psi{abs(psi):g}",
        repo=KIM[0],
        commit=KIM[1],
        path=f"{KIM_DIR}/Guidewire_Deflection.xlsx",
        also=(f"{KIM_DIR}/Flux_Density_B.txt",),
        kind="magnetic_bending",
        machine="Excel workbook (.xlsx) of the authors' figure data: sheet 'Figure 3C', one column of tip "
        "angles (deg, read from images to 0.5 deg) per mode and field angle, a row per distance",
        dims=f"{mode} mode, field angle {psi:+g} deg from the undeflected tip (the angle the tip "
        "reaches in the strongest field); field |B| 9-412 mT from the authors' COMSOL line along the magnet "
        "axis at height d - 50.8 mm; magnet moment and free length not in the data: 1 A m^2 and 1 m "
        "written, so the value is E_b / (m L) in T",
        source="README.txt (data S1 of Sci. Robot. 7, eabg9907); xlsx 'Figure 3C' rows 1-3 "
        "('Distance from magnet center (R = 50 mm)', 'phi=90', 'Guidewire Tip Angle'); "
        "Flux_Density_B.txt (COMSOL, model 'Cylindrical_4inch.mph': the on-axis field of a 4 in x 4 in "
        "cylinder, Br 1.44 T, within 2.2 mT)",
        specimen={"outer_diameter": "1 mm"},  # not in the data: labels the section only
        test={"free_length": "1 m", "magnet_moment": "1 A m^2"},
        hand=lambda p: hand.magnetic_tip(
            p,
            column=column,
            field_angle_deg=psi,
            field_file="Flux_Density_B.txt",
            half_length_m=0.0508,
        ),
        hand_text="B sin(psi - theta) against theta over the rows with |theta| <= 45 deg: line, slope "
        "E_b/(m L)",
        note="a distributed-magnetisation tip in a field with a gradient, not a tip magnet in a uniform "
        "field; the guidewire's diameter is not in the data (1 mm written: it labels the section only)",
    )


RECORDS: list[Record] = [
    vhb_relax("1d5", 0.5),
    vhb_relax("3d0", 2.0, encoding=None),  # this one file is UTF-8
    vhb_cycle("0d05_1d5_1"),
    vhb_cycle("0d01_1d5"),
    asen_torsion("jk-closed-ext", JK, "data/400inlb-solid.csv", slit=False, channel="ext"),
    asen_torsion("jk-closed-angle", JK, "data/400inlb-solid.csv", slit=False, channel="angle"),
    asen_torsion("jk-slit-ext", JK, "data/20inlb-slotted.csv", slit=True, channel="ext"),
    asen_torsion("jk-slit-angle", JK, "data/20inlb-slotted.csv", slit=True, channel="angle"),
    asen_torsion("cb-slit-angle", CB, "Lab 1/Torsion20inlbf_146.txt", slit=True, channel="angle"),
    asen_torsion("cb-slit-ext", CB, "Lab 1/Torsion20inlbf_146.txt", slit=True, channel="ext"),
    # the same course's slit tube a group later (Spring 2020, test run 122, 'ASEN3112_20in-lb-return'):
    # the machine's angle falls as the torque rises, so the study negates it
    *(
        asen_torsion(f"mc-slit-{ch}", MC, MC_OTW, slit=True, channel=ch, negate=True, source=ASEN_SRC_MC)
        for ch in ("angle", "ext")
    ),
    od_bend(1, "1_3D850_s1"),
    od_bend(4, "4_3Devo_s1"),
    od_bend(7, "7_CR10_s1"),
    Record(
        id="pz-tensile-1-5",
        repo=PZ[0],
        commit=PZ[1],
        path="examples/data/1-5.txt",
        kind="extension",
        machine="MTS TestSuite DAQ (Timed) txt, tab, decimal comma (unibz MTS)",
        dims="L0 33 mm (crosshead), A0 21.35 mm^2",
        source="examples/test4.py l.4-7 (Area0 = 21.35, length0 = 33)",
        specimen={"width": "7 mm", "height": "3.05 mm"},
        test={
            "gauge_length": "33 mm",
            "columns": {"time": "_Time", "elongation": "_Extension", "force": "_Load"},
            "window": {"elongation": ["0.3 mm", "0.8 mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=8,
            delim="\t",
            decimal=",",
            elong_col=0,
            force_col=1,
            gauge_m=0.033,
            window_m=(0.3e-3, 0.8e-3),
        ),
        hand_text="crosshead 0.3-0.8 mm (window also given to matid): line F(strain)",
        note="width x height only stand for A0 = 21.35 mm^2 (7 x 3.05); to failure: window stated",
    ),
    Record(
        id="es-tensile",
        repo=ES[0],
        commit=ES[1],
        path="example_input.dat",
        kind="extension",
        machine="tab-separated DAQ .dat, no header (README: Time s, Displacement mm, Force kN, Strain ue)",
        dims="none needed: strain-gauge strain column",
        source="README.md l.9-10 (column order and units)",
        specimen={"width": "10 mm", "height": "1 mm"},
        test={
            "gauge_length": "50 mm",
            "columns": {"time": 1, "force": 3, "strain": 4},  # by position: the file has no header
            "units": {"time": "s", "force": "kN", "strain": "µm/m"},
            "window": {"strain": [0.001, 0.003]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=0,
            delim="\t",
            decimal=".",
            elong_col=3,
            force_col=2,
            gauge_m=1.0,
            window_m=(1e-3, 3e-3),
            elong_si=1e-6,
            strain_col=True,
        ),
        hand_text="strain 1000-3000 microstrain (window also given to matid): line F(strain)",
        note="the file has no header row: columns named by position (README's order), units from the README",
    ),
    Record(
        id="rb-shimadzu-tract",
        repo=RB[0],
        commit=RB[1],
        path="Data/Exemple_Shimadzu_Tract_L100_D2.csv",
        kind="extension",
        machine="Shimadzu Trapezium CSV export (HEIG-VD COMATEC, 20 kN frame without extensometer): "
        "label row '\"C35\",,', quoted Temps/Force/Stroke over sec/N/mm, every number quoted",
        dims="L0 100 mm (crosshead stroke), D 2 mm",
        source="the file name's L100_D2 (the analyzer's L0 and D0, Extractor/ConfigWindow.py l.130, "
        "l.416-418); README.md l.33: 'Shimadzu - 20 [kN] maximum - Sans Extensometre'",
        specimen={"outer_diameter": "2 mm"},
        test={
            "gauge_length": "100 mm",
            "columns": {"time": "Temps", "elongation": "Stroke", "force": "Force"},
            "window": {"elongation": ["0.5 mm", "0.8 mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=3,
            delim=",",
            decimal=".",
            elong_col=2,
            force_col=1,
            gauge_m=0.1,
            window_m=(0.5e-3, 0.8e-3),
            force_si=1.0,
        ),
        hand_text="stroke 0.5-0.8 mm, past the grips' take-up and before the slope falls "
        "(window also given to matid): line F(strain)",
        note="apparent stiffness of the whole load train (crosshead stroke). E_e / (pi (1 mm)^2) = 195 GPa "
        "is steel-like, but an 8.3 kN peak on 2 mm would be 2.65 GPa for 'C35': D2 is uncertain; E_e "
        "does not use it",
    ),
    Record(
        id="rb-walterbai-tract2",
        repo=RB[0],
        commit=RB[1],
        path="Data/Exemple_WB100kN_2_Tract_L100_D2.csv",
        kind="extension",
        machine="Walter+Bai 100 kN frame export (HEIG-VD COMATEC): ';', units in brackets "
        "('C_1_Force[kN]', 'C_1_D\u00e9placement[mm]'), a row counter 'S/No' first, every row ending in ';'",
        dims="L0 100 mm (crosshead 'D\u00e9placement'), D 2 mm",
        source="the file name's L100_D2 (the analyzer's L0 and D0, Extractor/ConfigWindow.py l.130, "
        "l.416-418); README.md l.34: 'Walter & Bai - 100 [kN] maximum - Avec et sans extensometres' "
        "(the extensometer channel 'D\u00e9form1' has no gauge length in the repository: not used)",
        specimen={"outer_diameter": "2 mm"},
        test={
            "gauge_length": "100 mm",
            "columns": {"time": "C_1_Temps", "elongation": "C_1_D\u00e9placement", "force": "C_1_Force"},
            "window": {"elongation": ["1 mm", "2.5 mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=1,
            delim=";",
            decimal=".",
            elong_col=4,
            force_col=2,
            gauge_m=0.1,
            window_m=(1e-3, 2.5e-3),
        ),
        hand_text="crosshead 1-2.5 mm, past the toe (window also given to matid): line F(strain)",
        note="apparent stiffness of the load train (crosshead); its tangent falls slowly over the window",
    ),
    Record(
        id="pp-deben-nanocel",
        repo=TDA[0],
        commit=TDA[1],
        path="DATA/NANOCEL_KW.CHAL_450PPM_15.MTR",
        kind="extension",
        machine="Deben Microtest miniature tensile stage .MTR (Ver5.5.29, 200 N cell): 19 quoted header "
        "lines with decimal commas, quoted column names, no units row, a text column 'Motorspeed'",
        dims="span (gauge length) 10 mm; units mm, N, s given in the study (the file has none)",
        source="the file's header: line 3 'Span : 10,0', line 6 'Start Sampletime : 100ms' (Point "
        "steps 0.1 = s), line 18 'Max extension : 0,621mm', line 19 '200N tensile ... Calibrated at "
        "200N'; tda.py l.27-29 reads Elongation and Force after the 19 header lines",
        specimen={"width": "5 mm", "height": "1 mm"},
        test={
            "gauge_length": "10 mm",
            "columns": {"time": "Point", "elongation": "Elongation", "force": "Force"},
            "units": {"time": "s", "elongation": "mm", "force": "N"},
            "window": {"elongation": ["0.05 mm", "0.09 mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=20,
            delim=",",
            decimal=".",
            elong_col=1,
            force_col=2,
            gauge_m=0.01,
            window_m=(0.05e-3, 0.09e-3),
            force_si=1.0,
            first_cells=4,
        ),
        hand_text="elongation 0.05-0.09 mm, past the toe and before the film yields (window also given "
        "to matid): line F(strain)",
        note="nanocellulose film; width 5 and thickness 1 mm are the header's ('Sample : Default') and "
        "only label the section",
    ),
    Record(
        id="pp-deben-bc-cyclic",
        repo=TDA[0],
        commit=TDA[1],
        path="DATA/BC_0_W_R.013.MTR",
        kind="extension",
        machine="Deben Microtest .MTR as for pp-deben-nanocel, ending with the stage's end-of-test row "
        "'0,0,0,0,1,0,\"0\"' (file line 29395: time, elongation and force all 0)",
        dims="span (gauge length) 10 mm; units mm, N, s given in the study (the file has none)",
        source="the file's header: line 3 'Span : 10,0', line 4 'Width : 5,0', line 5 'Thickness : 1,0', "
        "line 6 'Start Sampletime : 100ms', line 11 'Number of points : 29374' (the last row is not one)",
        specimen={"width": "5 mm", "height": "1 mm"},
        test={
            "gauge_length": "10 mm",
            "columns": {"time": "Point", "elongation": "Elongation", "force": "Force"},
            "units": {"time": "s", "elongation": "mm", "force": "N"},
            "window": {"time": ["0 s", "124 s"], "elongation": ["0.45 mm", "0.85 mm"]},
        },
        hand=lambda p: hand.extension_window(
            p,
            skip=20,
            delim=",",
            decimal=".",
            elong_col=1,
            force_col=2,
            gauge_m=0.01,
            window_m=(0.45e-3, 0.85e-3),
            force_si=1.0,
            first_cells=4,
            until_s=124.0,
        ),
        hand_text="the first loading (time to 124 s, its first peak at 124.3 s), elongation 0.45-0.85 mm "
        "past the slack toe (window also given to matid): line F(strain)",
        note="wet bacterial cellulose cycled to growing peaks (0.88 to 5.38 mm) with a growing set: no one "
        "elastic line holds over the record, the first loading's tangent is the value (the whole record "
        "gives not_identifiable: tangent 6.9 N at strain 0.06, negative at 0.52)",
    ),
    bluehill("am1", "1016", delim=";", skip=6, header="re-saved: ';', empty first column (Latin-1)"),
    bluehill("am2", "1055", delim=",", skip=5, header="as exported: ',' with the results row above the data"),
    catman("HSM700_7_1", (0.13, 0.175)),
    catman("HSM700_7_2", (0.12, 0.165)),
    wavematrix("Test2", "5 load-unload cycles, 400 s, holds at the peaks"),
    wavematrix("Test5", "load-unload cycles, 33 s"),
    # Zwick testXpert II: the elastic line of each coupon, below the yield (steel) or where the
    # apparent stiffness of the Invar low-temperature coupon still falls slowly
    zwick(
        "Allong 1",
        "French",
        {"time": "Temps", "elongation": "Course standard", "force": "Force standard"},
        (1.0, 5.96, 25.0),
        (0.005, 0.03),
        (3, 2),
    ),
    zwick(
        "Invar_LT_05_01",
        "English",
        {"time": "Time", "elongation": "Standard travel", "force": "Standard force"},
        (1.5, 4.89, 30.0),
        (0.02, 0.1),
        (2, 3),
        note="apparent stiffness (81 GPa x A0, Invar is about 140 GPa): the standard travel of this "
        "low-temperature test includes more than the gauge length; its slope falls from the start. "
        "The author's import_from_txt.m (l.76-79) would take L0 from 'Capteur de course' (4.98 mm) "
        "instead; both matid and the hand script use the file's 30 mm",
    ),
    zwick(
        "mDB1pct",
        "English",
        {"time": "Time", "elongation": "Standard travel", "force": "Standard force"},
        (1.06, 6.02, 20.0),
        (0.01, 0.035),
        (3, 2),
    ),
    kim("attraction", "C", 90.0),
    kim("repulsion", "F", -90.0),
]


# --- study.toml -------------------------------------------------------------------------------


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{toml_value(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def study_toml(rec: Record, file: Path) -> str:
    lines = ["[study]", f"name = {toml_value('real record ' + rec.id)}", "", "[[specimen]]", 'id = "S1"']
    lines += [f"{k} = {toml_value(v)}" for k, v in rec.specimen.items()]
    lines += [
        "",
        "[[test]]",
        f"kind = {toml_value(rec.kind)}",
        'specimen = "S1"',
        f"file = {toml_value(str(file))}",
    ]
    lines += [f"{k} = {toml_value(v)}" for k, v in rec.test.items()]
    for p, v in rec.fixed.items():
        lines += [
            "",
            "[[fixed]]",
            'specimen = "S1"',
            f"parameter = {toml_value(p)}",
            f"value = {toml_value(v)}",
        ]
    return "\n".join(lines) + "\n"


# --- one record -------------------------------------------------------------------------------


@dataclass
class Outcome:
    rec: Record
    sha: str = ""
    value: float | None = None
    low: float | None = None
    high: float | None = None
    status: str = ""
    hand: float | None = None
    hand_n: int = 0
    seconds: float = 0.0
    reason: str = ""
    n_points: int = 0

    @property
    def diff(self) -> float | None:
        if self.value is None or not self.hand:
            return None
        return 100 * (self.value - self.hand) / self.hand

    @property
    def holds(self) -> bool:
        """Rule of issue 28 item 2. A not_identifiable value is printed without a number: it holds
        when matid's interval (:func:`estimate_interval`) covers the hand value."""
        if self.hand is None or (self.value is None and self.status != "not_identifiable"):
            return False
        if self.status == "ok":  # and never ok with an interval that excludes the hand value
            covers = self.low is not None and self.high is not None and self.low <= self.hand <= self.high
            return abs(self.diff) <= 5 and covers
        if self.status in ("check", "not_identifiable") and self.low is not None and self.high is not None:
            return self.low <= self.hand <= self.high
        return False


def flexural(E_b: float, S: float, E_s: float) -> float:
    """Flexural stiffness of a Timoshenko beam in 3-point bend: 1/(1/E_b + 12/(S^2 E_s))."""
    if E_s is None or not math.isfinite(E_s) or E_s <= 0:
        return float("nan")
    return 1 / (1 / E_b + 12 / (S**2 * E_s))


def run(rec: Record, path: Path) -> Outcome:
    import matid

    out = Outcome(rec, sha=hashlib.sha256(path.read_bytes()).hexdigest())
    out.hand, _, out.hand_n = rec.hand(path)
    with tempfile.TemporaryDirectory(prefix=f"real_{rec.id}_") as tmp:
        toml = Path(tmp) / "study.toml"
        shutil.copyfile(
            path, Path(tmp) / path.name
        )  # a byte copy: matid wants the file inside the study folder
        toml.write_text(study_toml(rec, Path(path.name)), encoding="utf-8")
        clock = time.perf_counter()
        try:
            result = matid.fit(toml)
        except Exception as exc:  # a refused file is a finding of the benchmark, not a crash of it
            out.seconds = time.perf_counter() - clock
            out.status = "refused"
            out.reason = f"{type(exc).__name__}: {exc}".replace("\n", " ")
            return out
        out.seconds = time.perf_counter() - clock
    table = result.table()
    rows = table[table.parameter == rec.parameter]
    if rows.empty and rec.parameter == "E_e":
        rows = table[table.parameter == "sls_k1"]
    if rows.empty:
        out.status = "failed"
        out.reason = "; ".join(result.failures) or "; ".join(result.warnings) or "no value"
        return out
    row = rows.iloc[0]
    out.status = str(row.status)
    out.n_points = int(row.n_points) if row.n_points is not None and row.n_points == row.n_points else 0
    out.reason = str(row.warnings or "")[:300]
    value, low, high = (
        None if row[k] is None or row[k] != row[k] else float(row[k])
        for k in ("value", "ci95_low", "ci95_high")
    )
    if out.status == "not_identifiable":  # no value printed: the rule reads matid's own interval
        low, high = estimate_interval(result, str(row.parameter))
    if rec.kind == "three_point_bend":
        E_b = float(rec.fixed["E_b"].split()[0])  # written in N m^2 above
        S = float(rec.test["span"].split()[0]) * 1e-3
        value, high = (flexural(E_b, S, v) if v is not None else None for v in (value, high))
        # E_s -> 0 takes the flexural stiffness to 0 (monotone): an E_s interval reaching 0 maps there
        low = None if low is None else (flexural(E_b, S, low) if low > 0 else 0.0)
    out.value, out.low, out.high = value, low, high
    return out


def estimate_interval(result, parameter: str) -> tuple[float | None, float | None]:
    """The 95 % interval of a withheld (not_identifiable) value, as matid's estimate holds it
    (the table prints neither value nor interval for it); (None, None) when it has none."""
    est = result.study_result.estimates().get("S1", {}).get(parameter)
    if est is None or est.ci95 is None or not all(math.isfinite(v) for v in est.ci95):
        return None, None
    return float(est.ci95[0]), float(est.ci95[1])


def fmt(v: float | None) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.4g}"


def line(o: Outcome) -> str:
    if o.value is None and o.low is not None:
        return (
            f"{o.rec.id:18s} {o.rec.kind:16s} matid - {o.status} [{fmt(o.low)}, {fmt(o.high)}] "
            f"hand {fmt(o.hand)} | rule {'holds' if o.holds else 'FAILS'} ({o.seconds:.1f} s)"
        )
    if o.value is None:
        return (
            f"{o.rec.id:18s} {o.rec.kind:16s} matid {o.status}: {o.reason[:240]} | hand {fmt(o.hand)} "
            f"| rule FAILS ({o.seconds:.1f} s)"
        )
    rule = "holds" if o.holds else "FAILS"
    return (
        f"{o.rec.id:18s} {o.rec.kind:16s} matid {fmt(o.value)} {o.status} [{fmt(o.low)}, {fmt(o.high)}] "
        f"hand {fmt(o.hand)} diff {o.diff:+.1f} % n {o.n_points} | rule {rule} ({o.seconds:.1f} s)"
    )


UNITS = {"extension": "N", "torsion": "N m^2", "three_point_bend": "N m^2", "magnetic_bending": "N m^2"}


def markdown(outcomes: list[Outcome], skipped: list[Record]) -> str:
    head = (
        "| id | repo @ commit | path | sha256 | kind | machine | dimensions (source) | hand (how) | "
        "matid | status | 95 % interval | diff % | rule |"
    )
    rows = [head, "|" + " --- |" * 13]
    for o in outcomes:
        r = o.rec
        diff = f"{o.diff:+.1f}" if o.diff is not None else "-"
        why = o.reason.replace("|", "/")[:200]
        status = o.status if o.status == "ok" or not why else f"{o.status}: {why}"
        rows.append(
            f"| {r.id} | {r.repo} @ {r.commit[:7]} | `{r.path}` | `{o.sha[:16]}…` | {r.kind} | {r.machine} | "
            f"{r.dims} ({r.source}) | {fmt(o.hand)} {UNITS[r.kind]} ({r.hand_text}; n = {o.hand_n}) | "
            f"{fmt(o.value)} | {status} | [{fmt(o.low)}, {fmt(o.high)}] | {diff} | "
            f"{'holds' if o.holds else 'FAILS'} |"
        )
    for r in skipped:
        rows.append(
            f"| {r.id} | {r.repo} @ {r.commit[:7]} | `{r.path}` | absent | {r.kind} | | | | | skipped | | | |"
        )
    return "\n".join(rows)


def copy_from_mirror(mirror: Path, records: Path) -> None:
    for rec in RECORDS:
        repo = mirror / rec.repo.replace("/", "+") / "repo"
        git_dir = repo / ".git" if (repo / ".git").is_dir() else repo
        for path in (rec.path, *rec.also):
            dest = records / rec.repo / path
            if dest.exists() or not git_dir.is_dir():
                continue
            data = subprocess.run(
                ["git", "--git-dir", str(git_dir), "show", f"{rec.commit}:{path}"],
                capture_output=True,
                check=True,
            ).stdout
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(data)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=Path, default=Path("/work/records"))
    ap.add_argument("--only", nargs="*", default=None, help="record ids to run")
    ap.add_argument("--copy-from-mirror", type=Path, default=None, help="e.g. /work/.mirror")
    args = ap.parse_args(argv)
    if args.copy_from_mirror:
        copy_from_mirror(args.copy_from_mirror, args.records)
    outcomes, skipped = [], []
    for rec in RECORDS:
        if args.only and rec.id not in args.only:
            continue
        path = args.records / rec.repo / rec.path
        if not path.is_file():
            print(f"{rec.id:18s} skipped: {path} is absent")
            skipped.append(rec)
            continue
        o = run(rec, path)
        print(line(o), flush=True)
        outcomes.append(o)
    print()
    print(markdown(outcomes, skipped))
    held = sum(o.holds for o in outcomes)
    print(f"\n{held} of {len(outcomes)} records hold the rule; {len(skipped)} skipped")
    return 0


if __name__ == "__main__":
    sys.exit(main())
