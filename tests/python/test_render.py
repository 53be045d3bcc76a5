"""raylab.render from Python: the image and its buffers, the same picture from every structure,
progress and cancellation, the ray counts, shadows, image files, bad input, and stability of shadows
far from the origin and at small scales (the robust ray offset against a fixed epsilon)."""
import math
import re
import shutil
import subprocess

import numpy as np
import pytest

import raylab
from conftest import load

W, H = 48, 36


def translation(t):
    m = np.eye(4)
    m[:3, 3] = t
    return m


def scaling(s):
    m = np.eye(4)
    m[0, 0] = m[1, 1] = m[2, 2] = s
    return m


def look_at(eye, target, up=(0.0, 0.0, 1.0)):
    """Camera-to-world matrix of a Blender camera at `eye` looking at `target` (down its local -Z)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return m


def box_mesh(lo, hi):
    """An axis-aligned box as 12 outward-wound triangles."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], np.float32)
    t = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]], np.uint32)
    return v, t


# The scene is 400 units across. At 1e4 an ulp is 0.001 and the robust offset (256 ulps) 0.25 units:
# that is what keeps a shadow ray off its own surface, and it is small against these boxes, so it
# moves the shadows' edges by a small fraction of a pixel.
BASE = np.diag([100.0, 100.0, 100.0, 1.0])
ENERGY = 400.0 * 100.0**2


def make_scene(structure="bvh", world=BASE):
    """A 4 x 4 floor with a box standing on it and a second, rotated box, times BASE; `world` places it."""
    scene = raylab.Scene(structure=structure, max_depth=6, leaf_size=8)
    floor = scene.add_mesh(*box_mesh((-2, -2, -0.1), (2, 2, 0)))
    box = scene.add_mesh(*box_mesh((-0.5, -0.5, 0), (0.5, 0.5, 1)))
    scene.add_instance(floor, world, material=0)
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(0.6), -math.sin(0.6)], [math.sin(0.6), math.cos(0.6)]]
    scene.add_instance(box, world @ translation((-0.6, 0.4, 0)) @ turn @ scaling(0.8), material=1)
    scene.add_instance(box, world @ translation((0.9, -0.7, 0)) @ scaling(0.5), material=0)
    scene.commit()
    return scene


def make_view(world=BASE, energy=ENERGY):
    camera = dict(type="PERSP", matrix_world=world @ look_at((3.0, -4.0, 3.0), (0.0, 0.0, 0.0)), lens=30.0,
                  resolution_x=W, resolution_y=H, resolution_percentage=100, clip_start=0.001, clip_end=1e5)
    lights = [dict(type="POINT", color=(1.0, 1.0, 1.0), energy=energy,
                   matrix_world=world @ translation((-2.0, -2.5, 2.5)))]
    materials = [dict(diffuse=(0.8, 0.8, 0.8), specular=0.2, shininess=20.0, ambient=0.1),
                 dict(diffuse=(0.8, 0.3, 0.2), reflectivity=0.3)]
    return camera, lights, materials


def render(scene, settings=None, world=BASE, energy=ENERGY, progress=None):
    camera, lights, materials = make_view(world, energy)
    settings = dict(dict(background=(0.1, 0.2, 0.3), ambient=(1.0, 1.0, 1.0)), **(settings or {}))
    return raylab.render(scene, camera, lights, materials, settings, progress=progress)


@pytest.fixture(scope="module")
def scene():
    return make_scene()


@pytest.fixture(scope="module")
def result(scene):
    return render(scene)


def test_image_and_buffers_have_the_agreed_shapes(result):
    assert result.image.shape == (H, W, 4) and result.image.dtype == np.float32
    assert result.instance.shape == (H, W) and result.instance.dtype == np.int32
    assert result.distance.shape == (H, W) and result.distance.dtype == np.float32
    assert not result.cancelled
    assert np.all(result.image[..., 3] == 1.0)
    hit = result.instance >= 0
    assert set(np.unique(result.instance)) == {-1, 0, 1, 2}
    assert np.all(np.isfinite(result.distance[hit])) and np.all(np.isinf(result.distance[~hit]))
    # Row 0 is the top of the picture: the camera looks down at the floor, whose near edge is at the bottom.
    floor = result.instance == 0
    assert result.distance[H // 2:][floor[H // 2:]].mean() < result.distance[:H // 2][floor[:H // 2]].mean()
    assert np.allclose(result.image[~hit][:, :3], (0.1, 0.2, 0.3))


def test_every_structure_renders_the_same_image(result):
    for structure in raylab.STRUCTURES:
        other = render(make_scene(structure))
        assert other.stats["structure"] == structure
        assert np.array_equal(other.image, result.image), structure
        assert np.array_equal(other.instance, result.instance), structure
        assert np.array_equal(other.distance, result.distance), structure
        assert other.stats["rays_shadow"] == result.stats["rays_shadow"], structure


def test_camera_rays_are_the_renderers_primary_rays(scene, result):
    # Tracing the camera's rays through every pixel centre finds what the render's primary hits found:
    # the probe and the renderer share this one camera model.
    camera, _, _ = make_view()
    ys, xs = np.mgrid[0:H, 0:W]
    origins, directions = raylab.camera_rays(camera, np.column_stack([xs.ravel(), ys.ravel()]) + 0.5)
    assert origins.shape == directions.shape == (W * H, 3)
    assert np.allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-6)
    hits = scene.intersect(origins, directions, tmin=camera["clip_start"])
    assert np.array_equal(hits.instance.reshape(H, W), result.instance)
    near = result.instance >= 0
    assert np.allclose(hits.t.reshape(H, W)[near], result.distance[near], rtol=1e-5)
    with pytest.raises(ValueError, match="points"):
        raylab.camera_rays(camera, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="finite"):
        raylab.camera_rays(camera, [[np.nan, 0.0]])


def test_stats_count_the_rays(scene, result):
    s = result.stats
    assert s["rays"] == sum(s[k] for k in ("rays_primary", "rays_shadow", "rays_reflection", "rays_refraction"))
    assert (s["width"], s["height"]) == (W, H)
    assert s["rays_primary"] == W * H
    assert 0 < s["rays_shadow"] <= W * H + s["rays_reflection"]  # one light: at most one per hit
    assert s["rays_reflection"] == 0 or s["rays_reflection"] <= np.count_nonzero(result.instance == 1)
    assert s["rays_refraction"] == 0
    assert s["box_tests"] > 0 and s["triangle_tests"] > 0 and s["nodes_visited"] > 0
    assert s["render_seconds"] > 0 and s["memory_bytes"] > 0 and s["build_seconds"] >= 0
    ss = render(scene, dict(super_sampling=3)).stats
    assert ss["rays_primary"] == W * H * 9
    # The primary-hit buffers come from the pixel centres whatever the sampling.
    even = render(scene, dict(super_sampling=2))
    assert even.stats["rays_primary"] == W * H * 4
    assert np.array_equal(even.instance, result.instance)


def test_progress_is_reported_and_true_cancels(scene):
    seen = []
    done = render(scene, progress=lambda f: seen.append(f))
    assert not done.cancelled and seen and all(0.0 <= f <= 1.0 for f in seen)
    cancelled = render(scene, progress=lambda f: True)
    assert cancelled.cancelled
    assert cancelled.stats["rays_primary"] < W * H


def test_exception_in_progress_cancels_and_is_raised(scene):
    def progress(fraction):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        render(scene, progress=progress)


def test_shadows_switch_darkens_only_the_shadowed_pixels(scene, result):
    unshadowed = render(scene, dict(shadows=False))
    assert unshadowed.stats["rays_shadow"] == 0
    brighter = unshadowed.image[..., 0] > result.image[..., 0] + 1e-6
    darker = unshadowed.image[..., 0] < result.image[..., 0] - 1e-6
    # The boxes shadow part of the floor; switching shadows off never darkens a pixel.
    assert brighter.sum() > 0.02 * W * H and not darker.any()
    floor_in_shadow = brighter & (result.instance == 0)
    assert floor_in_shadow.sum() > 0


def test_write_image_png_and_exr(tmp_path, result):
    for ext, magic in ((".png", b"\x89PNG\r\n\x1a\n"), (".exr", b"\x76\x2f\x31\x01")):
        path = tmp_path / f"render{ext}"
        raylab.write_image(path, result.image)
        data = path.read_bytes()
        assert data.startswith(magic) and len(data) > 200
        if shutil.which("oiiotool"):
            info = subprocess.run(["oiiotool", "--info", str(path)], capture_output=True, text=True).stdout
            assert re.search(rf"\b{W}\s+x\s+{H}, 4 channel", info), info
    with pytest.raises(RuntimeError, match="no_such_dir"):
        raylab.write_image(tmp_path / "no_such_dir" / "x.png", result.image)


def test_read_channels_gives_back_the_exr_write_image_wrote(tmp_path, result):
    from raylab import _raylab_images
    path = tmp_path / "render.exr"
    raylab.write_image(path, result.image)
    channels = _raylab_images.read_channels(path)
    assert list(channels) == ["R", "G", "B", "A"]
    for c, name in enumerate("RGBA"):
        assert channels[name].shape == (H, W) and np.array_equal(channels[name], result.image[..., c]), name
    with pytest.raises(RuntimeError, match="missing.exr"):
        _raylab_images.read_channels(tmp_path / "missing.exr")


def test_bad_input_raises_value_error_naming_it(scene):
    camera, lights, materials = make_view()
    with pytest.raises(ValueError, match="matrix_world"):
        raylab.render(scene, {k: v for k, v in camera.items() if k != "matrix_world"}, lights, materials, {})
    with pytest.raises(ValueError, match="lense"):
        raylab.render(scene, dict(camera, lense=50.0), lights, materials, {})
    with pytest.raises(ValueError, match="type"):
        raylab.render(scene, camera, [dict(lights[0], type="LASER")], materials, {})
    with pytest.raises(ValueError, match="material 1"):
        raylab.render(scene, camera, lights, materials[:1], {})
    for ss in (0, 5):
        with pytest.raises(ValueError, match="super_sampling"):
            raylab.render(scene, camera, lights, materials, dict(super_sampling=ss))
    with pytest.raises(ValueError, match="resolution_x"):
        raylab.render(scene, dict(camera, resolution_x=0), lights, materials, {})
    with pytest.raises(ValueError, match="matrix_world"):
        raylab.render(scene, dict(camera, matrix_world=np.eye(3)), lights, materials, {})
    with pytest.raises(TypeError):
        raylab.render("not a scene", camera, lights, materials, {})
    uncommitted = raylab.Scene()
    uncommitted.add_instance(uncommitted.add_mesh(*box_mesh((0, 0, 0), (1, 1, 1))), np.eye(4))
    with pytest.raises(RuntimeError, match="commit"):
        raylab.render(uncommitted, camera, lights, materials, {})


def lit_fraction(scene, settings, world=BASE, energy=ENERGY):
    """Fraction of the surface pixels that no shadow ray found blocked: shadows only take light away,
    so a pixel is shadowed exactly where it is darker than with shadows off."""
    on = render(scene, dict(settings, shadows=True), world, energy)
    off = render(scene, dict(settings, shadows=False), world, energy)
    hit = on.instance >= 0
    shadowed = (on.image[..., :3] < off.image[..., :3]).any(axis=2)
    return np.count_nonzero(~shadowed & hit) / np.count_nonzero(hit)


@pytest.mark.parametrize("name, world, energy", [
    ("translated to 1e4", translation((1e4, -1e4, 1e4)) @ BASE, ENERGY),
    ("scaled by 1e-3", scaling(1e-3) @ BASE, ENERGY * 1e-6),  # the same irradiance: energy / r^2
])
def test_shadows_stay_right_far_away_and_small_with_the_robust_offset(name, world, energy):
    reference = lit_fraction(make_scene(), dict(robust_offset=True))
    moved_scene = make_scene(world=world)
    robust = lit_fraction(moved_scene, dict(robust_offset=True), world, energy)
    fixed = lit_fraction(moved_scene, dict(robust_offset=False, fixed_epsilon=1e-4), world, energy)
    print(f"\n{name}: lit fraction at the origin {reference:.4f}, robust offset {robust:.4f}, "
          f"fixed epsilon 1e-4 {fixed:.4f}")
    assert abs(robust - reference) < 0.005
    if name.startswith("translated"):
        # 1e-4 is below half an ulp of 1e4: the offset rounds away and surfaces shadow themselves.
        assert fixed < reference - 0.1


def uv_sphere(segments=16, rings=8):
    """A coarse unit UV sphere, outward-wound: (V,3) vertices (their own normals), (T,3) triangles."""
    theta = np.linspace(0.0, math.pi, rings + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    ring = np.stack([np.outer(np.sin(theta), np.cos(phi)), np.outer(np.sin(theta), np.sin(phi)),
                     np.repeat(np.cos(theta)[:, None], segments, 1)], -1).reshape(-1, 3)
    vertices = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]]).astype(np.float32)
    south = len(vertices) - 1
    triangles = []
    for s in range(segments):
        n = (s + 1) % segments
        triangles.append([0, 1 + s, 1 + n])
        for r in range(rings - 2):
            a, b = 1 + r * segments + s, 1 + r * segments + n
            triangles += [[a, a + segments, b + segments], [a, b + segments, b]]
        last = 1 + (rings - 2) * segments
        triangles.append([last + s, south, last + n])
    return vertices, np.array(triangles, np.uint32)


def face_normals(vertices, triangles):
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    return np.repeat((n / np.linalg.norm(n, axis=1, keepdims=True))[:, None, :], 3, axis=1).astype(np.float32)


def render_sphere(normals, structure="bvh"):
    """A lone sphere lit from the upper left, 96 x 96, with the given shading normals."""
    scene = raylab.Scene(structure=structure)
    scene.add_instance(scene.add_mesh(*uv_sphere(), normals=normals), scaling(1.5))
    scene.commit()
    camera = dict(type="PERSP", matrix_world=look_at((0.0, -8.0, 0.5), (0.0, 0.0, 0.0)), lens=50.0,
                  resolution_x=96, resolution_y=96)
    lights = [dict(type="POINT", color=(1.0, 1.0, 1.0), energy=1000.0, matrix_world=translation((-4.0, -5.0, 3.0)))]
    materials = [dict(diffuse=(0.8, 0.8, 0.8), specular=0.0)]
    return raylab.render(scene, camera, lights, materials, dict(ambient=(0.0, 0.0, 0.0)))


def largest_step_across(result):
    """The largest brightness change between neighbouring sphere pixels on the middle row."""
    row = result.image[48, :, :3].mean(axis=1)
    on_sphere = np.flatnonzero(result.instance[48] >= 0)
    inner = row[on_sphere[1]:on_sphere[-1]]  # off the silhouette, where the background would step
    return np.abs(np.diff(inner)).max()


def test_smooth_normals_render_a_sphere_without_facets():
    vertices, triangles = uv_sphere()
    flat = render_sphere(None)
    smooth = render_sphere(vertices)  # a unit sphere's vertex is its own normal
    corners = render_sphere(vertices[triangles])  # the same normals given per corner
    assert np.array_equal(corners.image, smooth.image)
    assert np.array_equal(smooth.instance, flat.instance)  # the shape is the flat mesh's
    # Flat facets show as steps between neighbours; smooth shading leaves a gentle gradient.
    assert largest_step_across(smooth) < 0.35 * largest_step_across(flat)
    for structure in raylab.STRUCTURES:
        assert np.array_equal(render_sphere(vertices, structure).image, smooth.image), structure


def terminator_render(shadow_terminator, shadows=True):
    """A coarse smooth sphere lit by a sun from the side, seen from the front: the terminator runs
    down the middle. Returns the render and, per pixel, the smooth normal's cosine to the light
    (interpolated from the vertex normals at the primary hit; NaN off the sphere)."""
    vertices, triangles = uv_sphere(segments=12, rings=6)
    scene = raylab.Scene()
    scene.add_instance(scene.add_mesh(vertices, triangles, normals=vertices), np.eye(4))
    scene.commit()
    size = 96
    camera = dict(type="PERSP", matrix_world=look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0)), lens=50.0,
                  resolution_x=size, resolution_y=size)
    to_light = np.array([1.0, -0.3, 0.2]) / np.linalg.norm([1.0, -0.3, 0.2])
    sun = np.eye(4)
    sun[:3, :3] = look_at((0.0, 0.0, 0.0), -to_light)[:3, :3]  # a sun shines along its local -Z
    lights = [dict(type="SUN", color=(1.0, 1.0, 1.0), energy=3.0, matrix_world=sun)]
    materials = [dict(diffuse=(0.8, 0.8, 0.8), specular=0.0)]
    settings = dict(ambient=(0.0, 0.0, 0.0), shadows=shadows, shadow_terminator=shadow_terminator)
    result = raylab.render(scene, camera, lights, materials, settings)
    # The same pixels' primary rays, to know the smooth normal under each pixel.
    eye = np.array([0.0, -6.0, 0.0])
    half = math.tan(math.atan(0.5 * 36.0 / 50.0))
    x = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    px, pz = np.meshgrid(x * half, -x * half)
    directions = np.stack([px, np.ones_like(px), pz], -1).reshape(-1, 3)
    hits = scene.intersect(np.broadcast_to(eye, directions.shape), directions)
    w = np.stack([1.0 - hits.u - hits.v, hits.u, hits.v], -1)
    tri = np.where(hits.hit, hits.triangle, 0)
    normal = (w[:, :, None] * vertices[triangles[tri]]).sum(1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    cosine = np.where(hits.hit, normal @ to_light, np.nan).reshape(size, size)
    return result, cosine


def test_shadow_terminator_follows_the_smooth_normals():
    """Where the smooth normal faces the light, the pixel is lit: without the terminator point the
    facets' own edges cut the light off in steps (Hanika 2021)."""
    on, cosine = terminator_render(True)
    off, _ = terminator_render(False)
    brightness_on, brightness_off = on.image[..., :3].mean(-1), off.image[..., :3].mean(-1)
    assert np.array_equal(on.instance >= 0, ~np.isnan(cosine))  # the test's rays are the render's
    lit = cosine > 0.05  # in front of the light by the smooth normal
    lambert = 0.8 / math.pi * 3.0 * cosine  # albedo / pi * sun strength * cosine: smooth shading's value
    cut_off = brightness_off[lit] < 0.5 * lambert[lit]
    print(f"pixels lit by the smooth normal: {int(lit.sum())}; cut off by the facets: {int(cut_off.sum())} without "
          f"the terminator point, {int((brightness_on[lit] < 0.5 * lambert[lit]).sum())} with it")
    assert cut_off.mean() > 0.03  # the facet steps are there without it
    assert np.allclose(brightness_on[lit], lambert[lit], rtol=0.01)
    # Away from the terminator nothing changes, and unshadowed light is the same either way.
    far = cosine > 0.5
    assert np.allclose(brightness_on[far], brightness_off[far], atol=1e-6)
    unshadowed, _ = terminator_render(True, shadows=False)
    assert np.allclose(unshadowed.image[far], on.image[far], atol=1e-6)


def test_face_normals_render_as_flat_shading():
    vertices, triangles = uv_sphere()
    flat = render_sphere(None)
    given = render_sphere(face_normals(vertices, triangles))
    assert np.allclose(given.image, flat.image, atol=1e-5)


def test_bad_normals_raise_value_error():
    vertices, triangles = uv_sphere()
    scene = raylab.Scene()
    bad = np.array(vertices[triangles])
    bad[3, 1, 2] = np.nan
    for normals, message in [(vertices[:-1], "per-vertex"), (vertices[triangles][:-1], "per-corner"),
                             (np.zeros((len(triangles), 3, 2)), "per-corner"), (bad, "NaN")]:
        with pytest.raises(ValueError, match=message):
            scene.add_mesh(vertices, triangles, normals=normals)
    assert scene.mesh_count == 0  # a rejected mesh is not added
    mesh = scene.add_mesh(vertices, triangles)
    with pytest.raises(ValueError, match="NaN"):
        scene.replace_mesh(mesh, vertices, triangles, normals=bad)


@pytest.mark.parametrize("contract", list(raylab.CONTRACT_INFO))
@pytest.mark.parametrize("super_sampling", [1, 2])
def test_batches_render_as_one_ray_at_a_time(contract, super_sampling):
    """Camera and shadow rays in batches (the default) give the image, buffers, stats and cost of
    settings batches=False, bit for bit."""
    scene = raylab.Scene(structure="bvh", contract=contract)
    floor = scene.add_mesh(*box_mesh((-2, -2, -0.1), (2, 2, 0)))
    vertices, triangles = load("goathead")
    head = scene.add_mesh(vertices, triangles)
    scene.add_instance(floor, BASE, material=0)
    scene.add_instance(head, BASE @ translation((0.0, 0.0, 0.5)) @ scaling(0.8), material=1)
    scene.add_instance(head, BASE @ translation((1.0, -0.8, 0.3)) @ scaling(0.3), material=0)
    scene.commit()
    settings = dict(super_sampling=super_sampling, threads=1)
    batched = render(scene, settings)
    single = render(scene, dict(settings, batches=False))
    assert batched.stats["rays_shadow"] > 0 and batched.stats["rays_reflection"] > 0
    for name in ("image", "instance", "distance"):
        assert getattr(batched, name).tobytes() == getattr(single, name).tobytes(), name
    assert batched.cost.keys() == single.cost.keys()
    for name in batched.cost:
        assert batched.cost[name].tobytes() == single.cost[name].tobytes(), name
    numbers = {k: v for k, v in batched.stats.items() if k not in ("render_seconds", "build_seconds")}
    assert numbers == {k: v for k, v in single.stats.items() if k not in ("render_seconds", "build_seconds")}
