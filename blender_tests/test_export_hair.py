"""Hair export against Blender itself, in bpy 4.5 and Blender 3.4: strand and key counts,
key positions, radii, per-curve random (Cycles' hash) and materials, for legacy particle
hair (parents and children, two systems on one object) and Curves objects (geometry-nodes
made, with and without a radius attribute, and instanced through a collection)."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf.blender.export_scene import load_scene

pytestmark = pytest.mark.blender

PARTICLE_SCENE = r'''
import os
hb = register_engine()
from hairbsdf.blender.export_scene import export_scene, save_scene
scene = hs.reset(width=16, height=12, spp=1)
plane = hs.make_plane(size=2.0)
plane.location = (0.3, -0.2, 0.1)
plane.rotation_euler = (0.2, 0.1, 0.4)
plane.scale = (1.0, 2.0, 0.5)
hs.add_slot(plane, hs.diffuse_material("Slot0"))
hs.add_slot(plane, hs.hair_material("HairMat"))
# system 1: interpolated children (render 3 / viewport 2 per parent), shaped radius, closed tip
hs.add_particle_hair(plane, count=30, child_type="INTERPOLATED", children_render=3, children_display=2,
                     shape=0.4, material_slot=2, seed=1, render_step=3, display_step=2, name="H1")
# system 2: parents only, open tip, negative shape, material slot 1
hs.add_particle_hair(plane, count=12, child_type="NONE", shape=-0.3, close_tip=False, material_slot=1,
                     seed=2, render_step=2, display_step=1, name="H2", root=0.8, tip=0.1, radius_scale=0.03)
hs.make_camera()
hs.make_light("SUN")

# viewport export + Blender's own co_hair as the reference
dg = bpy.context.evaluated_depsgraph_get()
ev = plane.evaluated_get(dg)
desc, rep = export_scene(dg, render=False)
save_scene(os.path.join(TMP, "viewport.npz"), desc)
ref = []
for ps in ev.particle_systems:
    st = ps.settings
    totpart, totchild = len(ps.particles), len(ps.child_particles)
    totchild = int(totchild * st.display_percentage / 100.0)
    first = totpart if (st.child_type != "NONE" and totchild) else 0
    steps = 2 ** st.display_step + 1
    keys = [[list(ps.co_hair(ev, particle_no=p, step=s)) for s in range(steps)]
            for p in range(first, totpart + totchild)]
    ref.append({"keys": keys, "radius_scale": st.radius_scale, "root": st.root_radius, "tip": st.tip_radius,
                "shape": st.shape, "close_tip": st.use_close_tip, "material": st.material,
                "totpart": totpart, "children_render": st.rendered_child_count,
                "child_type": st.child_type, "render_step": st.render_step})

# final-render export through the engine (render depsgraph), no pixels
os.environ["HAIRBSDF_EXPORT_ONLY"] = "1"
os.environ["HAIRBSDF_DUMP_SCENE"] = os.path.join(TMP, "render.npz")
scene.render.engine = "HAIRBSDF"
bpy.ops.render.render()
from hairbsdf.blender import engine
emit({"ref": ref, "matrix": [list(r) for r in ev.matrix_world], "status": engine.LAST_RENDER.get("status"),
      "warnings": rep.all_warnings(), "slots": [s.material.name for s in ev.material_slots]})
'''


def _cycles_applies(matrix) -> bool:
    """Cycles moves curves to world space only under a uniform scale (rows and columns of the
    3 x 3 part of equal length); otherwise they stay in object space (docs/cycles.md §3.1)."""
    m3 = np.asarray(matrix, np.float64)[:3, :3]
    lengths = np.concatenate([(m3 ** 2).sum(axis=1), (m3 ** 2).sum(axis=0)])
    return bool(np.all(np.abs(lengths - lengths[0]) < 1e-6))


def _world_keys(curves):
    """The exported keys in world space (object-space curves through their transforms)."""
    pts = np.asarray(curves["points"], np.float64)
    if curves.get("curve_object") is None:
        return pts
    key_object = np.repeat(curves["curve_object"], np.diff(curves["curve_offsets"]))
    out = pts.copy()
    for k, m in enumerate(np.asarray(curves["object_transforms"]).reshape(-1, 3, 4)):
        sel = key_object == k
        out[sel, :3] = pts[sel, :3] @ m[:, :3].T + m[:, 3]
    return out


def _expected_radius(keys_world, matrix, sysref):
    """Cycles' particle radius from Blender's co_hair keys (independent of the exporter)."""
    m = np.asarray(matrix, np.float64)
    inv = np.linalg.inv(m)
    ko = keys_world @ inv[:3, :3].T + inv[:3, 3]
    seg = np.linalg.norm(np.diff(ko, axis=1), axis=2)
    t_along = np.concatenate([np.zeros((ko.shape[0], 1)), np.cumsum(seg, axis=1)], axis=1)
    total = t_along[:, -1:]
    t = np.where(total > 0, t_along / np.where(total > 0, total, 1), 0.0)
    r = 1.0 - t
    shape = sysref["shape"]
    if shape < 0:
        r = r ** (1.0 + shape)
    elif shape > 0:
        r = r ** (1.0 / (1.0 - shape))
    half = sysref["radius_scale"] * 0.5
    root, tip = half * sysref["root"], half * sysref["tip"]
    rad = r * (root - tip) + tip
    if sysref["close_tip"]:
        rad[:, -1] = 0.0
    return rad * abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0) if _cycles_applies(m) else rad


def test_particle_hair(run_blender, blender_kind, tmp_path):
    run = run_blender(blender_kind, PARTICLE_SCENE)
    out = run.result
    assert out["status"] == "exported", out
    m = np.asarray(out["matrix"])
    # ---- viewport: every key against Blender's co_hair
    desc, _ = load_scene(tmp_path / "viewport.npz")
    c = desc["curves"]
    offsets = c["curve_offsets"]
    counts = np.diff(offsets)
    pts = _world_keys(c)
    # the emitter's scale (1, 2, 0.5) is not uniform: its strands stay in its object space
    assert not _cycles_applies(m)
    assert np.all(c["curve_object"] == 0)
    np.testing.assert_allclose(np.asarray(c["object_transforms"]).reshape(3, 4), m[:3], atol=1e-6)
    ref = out["ref"]
    n_expected = [len(s["keys"]) for s in ref]
    assert ref[0]["child_type"] == "INTERPOLATED" and n_expected[0] == 30 * 2  # children only
    assert n_expected[1] == 12  # parents
    assert counts.size == sum(n_expected)
    start = 0
    for sysref, n in zip(ref, n_expected):
        keys = np.asarray(sysref["keys"], np.float64)  # (n, steps, 3) world space
        steps = keys.shape[1]
        assert np.all(counts[start:start + n] == steps)
        got = pts[offsets[start]:offsets[start + n]].reshape(n, steps, 4)
        np.testing.assert_allclose(got[..., :3], keys, atol=2e-5)
        np.testing.assert_allclose(got[..., 3], _expected_radius(keys, m, sysref), rtol=2e-5, atol=1e-7)
        start += n
    # random: Cycles' hash of the curve index over all systems of the object
    np.testing.assert_allclose(c["curve_random"], hairbsdf.cycles_curve_random(np.arange(counts.size)),
                               atol=1e-7)
    names = [mat["name"] for mat in desc["materials"]]
    mats = [names[i] for i in c["curve_material"]]
    assert set(mats[:n_expected[0]]) == {"HairMat"} and set(mats[n_expected[0]:]) == {"Slot0"}
    assert desc["materials"][names.index("HairMat")]["closures"][0]["type"] == "principled_hair"
    # ---- final render (engine depsgraph): render_step keys, rendered_child_count children
    rdesc, _ = load_scene(tmp_path / "render.npz")
    rc = rdesc["curves"]
    rcounts = np.diff(rc["curve_offsets"])
    n1, n2 = 30 * ref[0]["children_render"], 12
    assert rcounts.size == n1 + n2
    assert np.all(rcounts[:n1] == 2 ** ref[0]["render_step"] + 1)
    assert np.all(rcounts[n1:] == 2 ** ref[1]["render_step"] + 1)
    np.testing.assert_allclose(rc["curve_random"], hairbsdf.cycles_curve_random(np.arange(n1 + n2)), atol=1e-7)
    rp = rc["points"]
    det3 = 1.0  # object space: radii unscaled
    first = rp[rc["curve_offsets"][:-1], 3]
    last = rp[rc["curve_offsets"][1:] - 1, 3]
    np.testing.assert_allclose(first[:n1], 0.5 * 0.02 * 1.0 * det3, rtol=1e-5)   # root radius
    np.testing.assert_allclose(last[:n1], 0.0)                                     # closed tip
    np.testing.assert_allclose(first[n1:], 0.5 * 0.03 * 0.8 * det3, rtol=1e-5)
    np.testing.assert_allclose(last[n1:], 0.5 * 0.03 * 0.1 * det3, rtol=1e-5)     # open tip
    # the parents' roots are the same in viewport and render
    np.testing.assert_allclose(rp[rc["curve_offsets"][n1:-1], :3], c["points"][offsets[n_expected[0]:-1], :3],
                               atol=1e-5)
    assert rdesc["source"]["render"] is True and desc["source"]["render"] is False


CURVES_SCENE = r'''
import os
hb = register_engine()
from hairbsdf.blender.export_scene import export_scene, save_scene
scene = hs.reset(width=16, height=12, spp=1)
hm = hs.hair_material("CurvesHair", parametrization="COLOR")
other = hs.diffuse_material("Other")
# A: geometry-nodes made and realized, two key counts, transformed (det 2)
a = hs.curves_grid("A", nx=3, ny=2, n_points=5, radius=0.01, extra_grid=(2, 2, 7, 1.0), material=hm)
a.location = (0.5, 0.2, -0.3); a.rotation_euler = (0.3, -0.2, 0.8); a.scale = (2.0, 2.0, 0.5)
# C: no radius attribute -> Cycles' 0.005
c = hs.curves_grid("C", nx=2, ny=1, n_points=4, remove_radius=True, location=(0.0, 2.0, 0.0))
# B: un-realized geometry-nodes curve instances: not rendered by Cycles (warned)
b = hs.curves_grid("B", nx=2, ny=2, n_points=4, realize=False, location=(3.0, 0.0, 0.0))
# D: a Curves object instanced twice through a collection (one instance scaled x3)
coll = bpy.data.collections.new("HairColl")
scene.collection.children.link(coll)
src = hs.curves_grid("Src", nx=2, ny=1, n_points=4, radius=0.02, material=other)
scene.collection.objects.unlink(src)
coll.objects.link(src)
bpy.context.view_layer.layer_collection.children["HairColl"].exclude = True
for i, (loc, s) in enumerate((((-2.0, 0.0, 0.0), 1.0), ((-4.0, 1.0, 0.5), 3.0))):
    e = bpy.data.objects.new("Inst%d" % i, None)
    scene.collection.objects.link(e)
    e.instance_type = "COLLECTION"; e.instance_collection = coll; e.location = loc; e.scale = (s, s, s)
hs.make_camera(location=(0.0, -8.0, 1.0), target=(0.0, 0.0, 0.0))
dg = bpy.context.evaluated_depsgraph_get()
ref = []
for inst in dg.object_instances:
    o = inst.object
    if o.type != "CURVES" or len(o.data.curves) == 0:
        continue
    d = o.data
    pos = hs.curve_positions(o)
    ra = d.attributes.get("radius")
    rad = None
    if ra is not None:
        rad = np.empty(len(d.points), np.float32); ra.data.foreach_get("value", rad)
    ref.append({"name": o.name, "is_instance": inst.is_instance, "matrix": [list(r) for r in inst.matrix_world],
                "pos": pos, "radius": rad, "counts": [cv.points_length for cv in d.curves],
                "material": o.material_slots[0].material.name if len(o.material_slots) and o.material_slots[0].material else None})
desc, rep = export_scene(dg, render=False)
save_scene(os.path.join(TMP, "curves.npz"), desc)
emit({"ref": ref, "warnings": rep.all_warnings()})
'''


def test_curves(run_blender, blender_kind, tmp_path):
    out = run_blender(blender_kind, CURVES_SCENE).result
    desc, _ = load_scene(tmp_path / "curves.npz")
    c = desc["curves"]
    offsets = c["curve_offsets"]
    counts = np.diff(offsets)
    ref = out["ref"]
    names = [r["name"] for r in ref]
    assert sorted(names) == ["A", "C", "Src", "Src"], names
    assert sum(r["is_instance"] for r in ref) == 2
    exp_pts, exp_counts, exp_rand, exp_mat = [], [], [], []
    for r in ref:
        m = np.asarray(r["matrix"])
        p = np.asarray(r["pos"], np.float64).reshape(-1, 3)
        world = p @ m[:3, :3].T + m[:3, 3]
        rad = np.full(len(p), 0.005) if r["radius"] is None else np.asarray(r["radius"])
        if _cycles_applies(m):
            rad = rad * abs(np.linalg.det(m[:3, :3])) ** (1 / 3)
        exp_pts.append(np.column_stack([world, rad]))
        exp_counts.append(r["counts"])
        exp_rand.append(hairbsdf.cycles_curve_random(np.arange(len(r["counts"]))))
        exp_mat += [r["material"] or "__default__"] * len(r["counts"])
    exp_counts = np.concatenate(exp_counts)
    assert sorted(set(exp_counts.tolist())) == [4, 5, 7]  # varying key counts in one object
    np.testing.assert_array_equal(counts, exp_counts)
    np.testing.assert_allclose(_world_keys(c), np.concatenate(exp_pts), rtol=1e-5, atol=2e-6)
    np.testing.assert_allclose(c["curve_random"], np.concatenate(exp_rand), atol=1e-7)
    mat_names = [desc["materials"][i]["name"] for i in c["curve_material"]]
    assert mat_names == exp_mat
    assert "CurvesHair" in mat_names and "Other" in mat_names
    # radius defaults and transform scale, spelled out
    a = names.index("A")  # scale (2, 2, 0.5): kept in object space, radius unscaled
    assert np.allclose(exp_pts[a][:, 3], 0.01, rtol=1e-5)
    kept = np.flatnonzero(c["curve_object"] >= 0)
    assert kept.size == len(ref[a]["counts"]) and np.all(c["curve_object"][kept] == c["curve_object"][kept[0]])
    assert np.allclose(exp_pts[names.index("C")][:, 3], 0.005)
    scaled = [e for r, e in zip(ref, exp_pts) if r["name"] == "Src"]
    assert sorted(np.round([e[0, 3] for e in scaled], 6)) == pytest.approx([0.02, 0.06])
    assert any("un-realized geometry-nodes curve instance" in w and "'B'" in w for w in out["warnings"]), \
        out["warnings"]
    # Curves' Length attribute (curve_intercept_total) is the object-space polyline length
    assert c["curve_intercept_total"].shape == counts.shape
    assert np.all(c["curve_intercept_total"] > 0)


HUANG_NORMALS_SCENE = r'''
import os
import scene_lib as lib
register_engine()
from hairbsdf.blender.export_scene import export_scene, save_scene
scene = hs.reset(width=16, height=12, spp=1)
huang = lib.hair_material("HuangHair", dict(model="HUANG", parametrization="COLOR", aspect_ratio=0.6))
chiang = lib.hair_material("ChiangHair", dict(parametrization="COLOR"))
lines = [[(0.1 * k, 0.3 * j, 0.0) for k in range(5)] for j in range(2)]  # along +X
lib.curves_from_polylines(scene, "HuangCurves", lines, 0.01, huang, curve_normal="Z_UP")
lib.curves_from_polylines(scene, "ChiangCurves", [[(0.1 * k, 1.0, 0.0) for k in range(4)]], 0.01, chiang)
hs.make_camera(location=(0.2, -3.0, 0.5), target=(0.2, 0.5, 0.0))
desc, rep = export_scene(bpy.context.evaluated_depsgraph_get(), render=False)
save_scene(os.path.join(TMP, "huang.npz"), desc)
emit({"warnings": rep.all_warnings()})
'''


def test_curve_normals_for_huang(run_blender, tmp_path):
    """Curves with a Huang material export their world-space curve normals (the ellipse's major
    axis, here Set Curve Normal > Z Up; Blender 4.5's foreach_get on Curves.normals reads
    freed memory, item 0 came back as garbage); other strands get zero (Cycles' fallback frame)."""
    run_blender("bpy", HUANG_NORMALS_SCENE)
    desc, _ = load_scene(tmp_path / "huang.npz")
    c = desc["curves"]
    assert "normals" in c, sorted(c)
    n = np.asarray(c["normals"])
    counts = np.diff(c["curve_offsets"])
    assert n.shape == (len(c["points"]), 3)
    names = [desc["materials"][i]["name"] for i in np.repeat(c["curve_material"], counts)]
    huang = np.array([m == "HuangHair" for m in names])
    assert huang.sum() == 10 and (~huang).sum() == 4
    assert np.all(n[~huang] == 0)
    # Z Up: perpendicular to Z and to the tangent (+X), i.e. along Y
    np.testing.assert_allclose(np.abs(n[huang]), np.tile([0.0, 1.0, 0.0], (10, 1)), atol=1e-4)
