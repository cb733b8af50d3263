"""The Python package is a door to the same application layer as the command line: the built-in
default runs with no config, one SFR and one ISP whichever door measures, patches numbered 1-24
with their names, every name camsim takes listed from its tables."""

import json
import pathlib
import subprocess

import camsim
import numpy as np
from conftest import camsim_binary

REPO = pathlib.Path(__file__).resolve().parents[3]


def run(*args):
    subprocess.run([camsim_binary(), *map(str, args), "--quiet"], check=True)


def test_simulate_with_no_config_runs_the_builtin_default():
    sim = camsim.simulate()
    assert sim.raw.shape == (1, 480, 640) and sim.cfa == "RGGB"
    assert sim.config == camsim.presets.simulate() == camsim.load_config()
    assert sim.chart_corners is not None  # the default is the ColorChecker


def test_one_sfr_through_the_cli_and_python(tmp_path):
    run("simulate", REPO / "examples" / "slanted-edge.toml", "--out", tmp_path / "sim")
    out = tmp_path / "sfr"
    p = subprocess.run([camsim_binary(), "analyze", "sfr", str(tmp_path / "sim" / "raw.dng"), "--json", "--quiet",
                        "--out", str(out)], check=True, capture_output=True, text=True)
    cli = {c["curve"]: c for c in json.loads(p.stdout)["curves"]}
    d = camsim.read_dng(tmp_path / "sim" / "raw.dng")
    for channel in ("R", "G", "B", "luminance"):
        py = camsim.sfr(d["raw"], d["cfa"], channel=channel, bits=d["bits"], black_level=d["black_level"])
        assert py["mtf50_cyc_per_sensor_px"] == cli[channel]["mtf50_cyc_per_sensor_px"], channel
        assert py["mtf_at_nyquist"] == cli[channel]["mtf_at_nyquist"], channel
        assert py["edge_angle_deg"] == cli[channel]["edge_angle_deg"], channel


def test_one_isp_through_simulate_the_cli_and_python(tmp_path):
    cfg = (REPO / "crates" / "camsim-cli" / "tests" / "small-chart.toml").read_text()
    cfg = cfg.replace("border_px = 2", 'border_px = 2\nilluminant = "F11"')
    (tmp_path / "run.toml").write_text(cfg)
    sim = camsim.simulate(tmp_path / "run.toml")
    preview, report = camsim.isp(sim.raw[0], sim.cfa, sensor="pixel4a", bits=sim.bits, black_level=sim.black_level,
                                 illuminant="F11")
    assert np.array_equal(preview, sim.preview)
    assert report["white_balance"] == "illuminant" and report["white_balance_gains"][1] == 1.0
    sim.write(tmp_path / "sim", save="raw")
    run("isp", "--in", tmp_path / "sim" / "raw.dng", "--sensor", "pixel4a", "--illuminant", "F11", "--out", tmp_path / "isp.png")
    from PIL import Image

    assert np.array_equal(np.asarray(Image.open(tmp_path / "isp.png")), sim.preview)


def test_isp_steps_through_the_config_and_through_python_give_one_preview(tmp_path):
    """The keys of [isp] (defect correction, denoising, sharpening, tone curve) reach the ISP the
    same way from a simulate config and from `camsim.isp(..., steps=...)`; without them the
    preview differs, and an unknown key is refused."""
    steps = {"defect_correction": "detect", "defect_sigmas": 5.0, "denoise": "nlm", "denoise_strength": 1.5,
             "sharpen": {"radius_px": 1.2, "amount": 0.6, "threshold": 2.0}, "tone_map": "reinhard"}
    cfg = (REPO / "crates" / "camsim-cli" / "tests" / "small-chart.toml").read_text()
    cfg += "\n[isp]\n" + "".join(
        f"{k} = {json.dumps(v) if not isinstance(v, dict) else '{ ' + ', '.join(f'{a} = {b}' for a, b in v.items()) + ' }'}\n"
        for k, v in steps.items())
    (tmp_path / "run.toml").write_text(cfg)
    sim = camsim.simulate(tmp_path / "run.toml")
    args = dict(sensor="pixel4a", bits=sim.bits, black_level=sim.black_level)
    preview, _ = camsim.isp(sim.raw[0], sim.cfa, steps=steps, **args)
    assert np.array_equal(preview, sim.preview)
    plain, _ = camsim.isp(sim.raw[0], sim.cfa, steps={"tone_map": "reinhard"}, **args)
    assert not np.array_equal(plain, sim.preview)
    try:
        camsim.isp(sim.raw[0], sim.cfa, steps={"denoize": "nlm"}, **args)
    except camsim.CamsimError as e:
        assert "denoize" in str(e)
    else:
        raise AssertionError("an unknown step was accepted")


def test_chart_patches_are_numbered_1_to_24_with_their_names():
    cfg = camsim.load_config()
    # A window the default chart fits in (it spans about 600 x 400 pixels).
    cfg["sensor"].update(rows=480, cols=640)
    cfg["capture"]["exposure_ms"] = 5.0
    sim = camsim.simulate(cfg)
    patches = camsim.chart(sim.raw[0], sim.chart_corners, sim.cfa, bits=sim.bits, black_level=sim.black_level)
    assert [p["patch"] for p in patches] == list(range(1, 25))
    assert (patches[0]["name"], patches[18]["name"], patches[23]["name"]) == ("dark skin", "white", "black")
    # The white patch (19) is the brightest, the black (24) the darkest, in green.
    g = [p["mean"][1] for p in patches]
    assert g.index(max(g)) == 18 and g.index(min(g)) == 23


def test_every_name_camsim_takes_is_listed():
    names = camsim.presets.names()
    assert "pixel4a-raw10" in names["sensor presets"] and "pixel4a-measured" in names["lens presets"]
    assert len(names["2D scene kinds"]) == 17 and {"dead_leaves", "glare_target", "hdr_chart", "hdr_lights"} <= set(names["2D scene kinds"])
    assert names["demosaic methods"] == ["bilinear", "malvar", "adaptive-laplacian"]
    assert "raw-npy" in names["dataset outputs"] and "quad-bayer" in names["colour filter arrays"]
    for kind in names["2D scene kinds"]:
        if kind not in ("file", "rgb"):  # those need a file
            assert camsim.scene(kind)["radiance"].ndim == 3, kind


def test_the_type_stub_names_exactly_what_the_compiled_module_has():
    """_camsim.pyi (what type checkers and editors read) must list every function of the
    compiled module and every member of Simulation, and nothing that is not there: a renamed
    function otherwise keeps its old name in the stub unnoticed."""
    import ast

    from camsim import _camsim

    stub = pathlib.Path(camsim.__file__).with_name("_camsim.pyi")
    tree = ast.parse(stub.read_text())
    stub_funcs = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    stub_sim = {
        m.name
        for c in tree.body
        if isinstance(c, ast.ClassDef) and c.name == "Simulation"
        for m in c.body
        if isinstance(m, ast.FunctionDef)
    }
    module_funcs = {
        n for n in dir(_camsim) if not n.startswith("_") and callable(getattr(_camsim, n)) and not isinstance(getattr(_camsim, n), type)
    }
    sim_members = {n for n in dir(_camsim.Simulation) if not n.startswith("_")}
    assert stub_funcs == module_funcs, (
        f"only in the stub: {sorted(stub_funcs - module_funcs)}; only in the module: {sorted(module_funcs - stub_funcs)}"
    )
    assert stub_sim == sim_members, (
        f"only in the stub: {sorted(stub_sim - sim_members)}; only in the module: {sorted(sim_members - stub_sim)}"
    )
