"""`hairbsdf plot` (docs/fit.md): the slices look where they say, the command writes PNGs."""

import subprocess
import sys

import numpy as np
import pytest

from hairbsdf import cli, epic_hair, gonio, principled_hair
from hairbsdf.plot import azimuthal_slice, longitudinal_slice

PNG = b"\x89PNG\r\n\x1a\n"


def test_slices_are_the_documented_directions():
    hair = epic_hair(roughness=0.3)
    theta_o = np.radians(30.0)
    wo = np.array([np.sin(theta_o), np.cos(theta_o), 0.0])
    t, lobes = longitudinal_slice(hair, theta_o, count=9)  # t = 0, 45, ..., 360 degrees
    # t (degrees) -> (theta_i, delta_phi): the view's side of the fibre is delta_phi = 0
    expected = {45: (45, 0), 90: (0, 0), 135: (-45, 0), 225: (-45, 180), 270: (0, 180), 315: (45, 180)}
    for k, (theta_i, delta_phi) in expected.items():
        wi = gonio.direction(np.radians(theta_i), np.radians(delta_phi))
        assert np.allclose(lobes[k // 45], hair.eval_lobes(wo, wi, 0.0)[0], rtol=1e-9, atol=1e-300), k
    assert lobes[2].sum() > 1e-4  # t = 90: not a trivially zero comparison
    phi, lobes = azimuthal_slice(hair, theta_o, count=5)  # delta_phi = -180, -90, 0, 90, 180 degrees
    mirror = np.array([-np.sin(theta_o), np.cos(theta_o), 0.0])  # theta_i = -theta_o, delta_phi = 0
    assert np.allclose(lobes[2], hair.eval_lobes(wo, mirror, 0.0)[0], rtol=1e-9, atol=1e-300)
    assert lobes[2].sum() > 1e-2


def test_h_average_of_chiang_differs_from_h0_and_matches_the_mean():
    hair = principled_hair(parametrization="melanin", melanin=0.3)
    wo, wi = gonio.direction(0.2, 0.0), gonio.direction(-0.3, 2.8)
    averaged = gonio.far_field_lobes(hair, wo, wi, 64, True)[0]
    h = np.linspace(-1, 1, 20001)
    mean = hair.eval_lobes(np.tile(wo, (len(h), 1)), np.tile(wi, (len(h), 1)), h).mean(axis=0)
    assert np.allclose(averaged, mean, rtol=2e-3, atol=1e-6)
    assert not np.allclose(averaged, hair.eval_lobes(wo, wi, 0.0)[0], rtol=1e-2)


def test_plot_writes_non_empty_pngs(tmp_path, capsys):
    rc = cli.main(["plot", "principled_hair(melanin=0.5)", "--out", str(tmp_path), "--theta-o", "30",
                   "--resolution", "12", "--h-nodes", "4"])
    assert rc == 0
    printed = capsys.readouterr().out.split()
    for kind in ("polar", "heatmap", "albedo"):
        path = tmp_path / f"principled_hair_{kind}.png"
        assert str(path) in printed
        data = path.read_bytes()
        assert data[:8] == PNG and len(data) > 10_000, kind
    # --only and --name: just the one file
    assert cli.main(["plot", "epic", "--out", str(tmp_path / "e"), "--only", "polar", "--name", "x",
                     "--theta-o", "0"]) == 0
    assert [p.name for p in (tmp_path / "e").iterdir()] == ["x_polar.png"]


def test_plot_rejects_bad_input(tmp_path, capsys):
    for argv, fragment in ((["plot", "exec('1')"], "unknown constructor"),
                           (["plot", "epic", "--theta-o", "0,a"], "--theta-o"),
                           (["plot", "epic", "--theta-o", "95"], "(-90, 90)"),
                           (["plot", "epic", "--tolerance", "0.1"], "only Huang"),
                           (["plot", "principled_hair(model='huang')", "--tolerance", "0.9"], "allowed: [1e-06, 0.5]")):
        with pytest.raises(SystemExit) as exc:
            cli.main(argv + ["--out", str(tmp_path)])
        assert exc.value.code == 2 and fragment in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_plot_help():
    r = subprocess.run([sys.executable, "-m", "hairbsdf.cli", "plot", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "--out" in r.stdout and "SPEC" in r.stdout.upper()
    # Huang's coarser defaults are stated (issue 28).
    assert "32 for Huang" in r.stdout and "--tolerance" in r.stdout


def test_plot_uses_coarser_defaults_for_huang(monkeypatch, tmp_path):
    from pathlib import Path

    from hairbsdf import plot
    seen = {}
    monkeypatch.setattr(plot, "heatmap_figure", lambda spec, path, **kw: seen.setdefault("heatmap", kw) and Path(path))
    monkeypatch.setattr(plot, "lobe_polar_figure", lambda spec, path, **kw: seen.setdefault("polar", kw) and Path(path))
    monkeypatch.setattr(plot, "albedo_figure", lambda spec, path, **kw: seen.setdefault("albedo", kw) and Path(path))
    assert plot.main(["principled_hair(model='huang')", "--out", str(tmp_path)]) == 0
    assert seen["heatmap"]["resolution"] == plot.HUANG_RESOLUTION and seen["polar"]["count"] == plot.HUANG_SLICE_POINTS
    assert all(kw["tolerance"] == plot.HUANG_PLOT_TOLERANCE for kw in seen.values())
    seen.clear()
    assert plot.main(["principled_hair()", "--out", str(tmp_path), "--only", "heatmap"]) == 0
    assert seen["heatmap"]["resolution"] == plot.DEFAULT_RESOLUTION and "tolerance" not in seen["heatmap"]

