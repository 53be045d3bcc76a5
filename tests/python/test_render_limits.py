"""What the renderer accepts it renders as numbers: every material and light parameter at the edges of
its accepted range gives finite pixels, a gain beyond the range is a ValueError naming it, write_image
refuses an image with NaN or infinite pixels, and a resolution beyond the render's memory budget is
refused before anything is allocated."""
import itertools

import numpy as np
import pytest

import raylab
from test_render import look_at, make_scene, translation

BIG = float(np.finfo(np.float32).max)
TINY = float(np.finfo(np.float32).tiny)

# Each parameter's extremes inside its accepted range (finite values for the unbounded ones).
MATERIAL_EXTREMES = {
    "diffuse": [(1e3, 1e3, 1e3), (-1e3, -1e3, -1e3), (0.0, 0.0, 0.0)],
    "specular": [1e3, 0.0],
    "shininess": [1e6, 0.0],
    "metallic": [0.0, 1.0],
    "reflectivity": [0.0, 1.0],
    "transmission": [0.0, 1.0],
    "ior": [1e-3, 1e3],
    "ambient": [BIG, -BIG],
}
LIGHT_EXTREMES = {
    "color": [(BIG, BIG, BIG), (0.0, 0.0, 0.0)],
    "energy": [BIG, -BIG, TINY],
    "size": [BIG, TINY],
    "spot_size": [np.pi, 1e-6],
    "spot_blend": [0.0, 1.0],
    "samples": [1, 8],
    "radius": [BIG],
}
LIGHT_TYPES = ("POINT", "SUN", "SPOT", "AREA")


def render(materials, lights, settings=None):
    """make_scene's floor and boxes, 24 x 18 pixels, the camera looking down at them."""
    camera = dict(type="PERSP", matrix_world=np.diag([100.0, 100.0, 100.0, 1.0]) @ look_at((3.0, -4.0, 3.0), (0, 0, 0)),
                  lens=30.0, resolution_x=24, resolution_y=18, clip_start=0.001, clip_end=1e5)
    return raylab.render(make_scene(), camera, lights, materials, dict(max_recursion=4, **(settings or {})))


def light(kind, **extra):
    """A light above the boxes (the scene is 400 units across), shining down at them."""
    return {**dict(type=kind, energy=4e6, matrix_world=translation((0.0, 0.0, 250.0))), **extra}


@pytest.mark.parametrize("name", MATERIAL_EXTREMES)
def test_extreme_materials_give_finite_pixels(name):
    for value, kind in itertools.product(MATERIAL_EXTREMES[name], LIGHT_TYPES):
        materials = [dict(**{name: value}), dict(**{name: value}, reflectivity=0.5)] if name != "reflectivity" else \
            [dict(reflectivity=value)] * 2
        # The brightest colour and energy, either sign, and a light on the floor itself.
        lights = [light(kind), light(kind, energy=BIG), light(kind, energy=-BIG),
                  light(kind, energy=BIG, color=(BIG, BIG, BIG), matrix_world=translation((0.0, 0.0, 0.0)))]
        image = render(materials, lights, dict(ambient=(BIG, BIG, BIG))).image
        assert np.isfinite(image).all(), f"{name}={value} under {kind} lights"


@pytest.mark.parametrize("name", LIGHT_EXTREMES)
def test_extreme_lights_give_finite_pixels(name):
    materials = [dict(specular=1e3, shininess=1e6), dict(diffuse=(1e3, 1e3, 1e3), metallic=1.0)]
    for value, kind in itertools.product(LIGHT_EXTREMES[name], LIGHT_TYPES):
        lights = [light(kind, **{name: value}), light(kind, **{"energy": BIG, name: value})]
        image = render(materials, lights).image
        assert np.isfinite(image).all(), f"{name}={value} on a {kind} light"


@pytest.mark.parametrize("name, value, accepted", [
    ("specular", 1e38, "specular must be 0 to 1000"),
    ("shininess", 1e7, r"shininess must be 0 to 1e\+06"),
    ("diffuse", (1e4, 0.0, 0.0), r"diffuse must be finite, each component within \+-1000"),
    ("ior", 0.0, "ior must be 0.001 to 1000"),
])
def test_a_gain_beyond_its_range_is_refused_naming_it(name, value, accepted):
    with pytest.raises(ValueError, match=r"materials\[1\]: " + accepted):
        render([dict(), dict(**{name: value})], [light("POINT")])


def test_a_background_beyond_the_radiance_limit_is_refused():
    with pytest.raises(ValueError, match=r"background must be finite, each component within \+-1e\+20"):
        render([dict()] * 2, [light("POINT")], dict(background=(1e38, 0.0, 0.0)))


@pytest.mark.parametrize("extension", ["png", "exr"])
def test_write_image_refuses_nan_pixels_saying_how_many_and_where(tmp_path, extension):
    image = np.full((4, 6, 4), 0.5, np.float32)
    image[1, 2, 0] = np.nan
    image[3, 5, 3] = np.inf
    path = tmp_path / f"nan.{extension}"
    with pytest.raises(ValueError, match=r"2 of its 24 pixels are not finite \(NaN or infinite\), the first at row 1, "
                                         r"column 2"):
        raylab.write_image(path, image)
    assert not path.exists()
    raylab.write_image(path, np.nan_to_num(image))  # the same picture with numbers is written
    assert path.exists()


def test_a_resolution_beyond_the_memory_budget_is_refused_at_validation():
    camera = dict(type="PERSP", matrix_world=np.eye(4), resolution_x=46341, resolution_y=46341)
    with pytest.raises(ValueError, match=r"width x height 46341 x 46341 at super_sampling 2 .* needs about "
                                         r"\d+ bytes, over the render's memory_budget of 4294967296 bytes"):
        raylab.render(make_scene(), camera, [light("POINT")], [dict()] * 2, dict(super_sampling=2))
    # The budget is a setting: a small one refuses a small picture.
    camera.update(resolution_x=24, resolution_y=18)
    with pytest.raises(ValueError, match="memory_budget"):
        raylab.render(make_scene(), camera, [light("POINT")], [dict()] * 2, dict(memory_budget=1000))
    with pytest.raises(ValueError, match=r"settings\['memory_budget'\] must be positive"):
        raylab.render(make_scene(), camera, [light("POINT")], [dict()] * 2, dict(memory_budget=0))
