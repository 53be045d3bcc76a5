"""The renderer's per-pixel cost buffers (render(...).cost): every counter per pixel, summed over the
rays settings["cost_rays"] names, equal to the totals and to the API's per-ray counts of the same rays."""
import numpy as np
import pytest

import raylab
from test_render import H, W, make_scene, make_view, render


def test_the_cost_passes_name_counters_once():
    assert raylab.COST_PASSES and len(set(raylab.COST_PASSES)) == len(raylab.COST_PASSES)
    counters = [info["counter"] for info in raylab.COST_PASS_INFO.values()]
    assert set(counters) <= set(raylab.COUNTERS) and len(set(counters)) == len(counters)
    assert {"rays", "box_tests", "triangle_tests", "nodes_visited"} <= set(counters)
    assert raylab.COST_RAYS == ("all", "primary")


@pytest.mark.parametrize("super_sampling", [1, 2])
def test_every_pixels_cost_adds_up_to_the_render_totals(super_sampling):
    result = render(make_scene(), dict(super_sampling=super_sampling))
    assert tuple(result.cost) == raylab.COUNTERS
    assert result.stats["rays_reflection"] > 0 and result.stats["rays_shadow"] > 0  # more than primary rays
    for name, values in result.cost.items():
        assert values.shape == (H, W) and values.dtype == np.float32, name
        assert int(values.sum(dtype=np.float64)) == result.stats[name], name
    assert (result.cost["rays"] >= super_sampling ** 2).all()


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_primary_cost_equals_the_api_counts_of_the_pixel_centre_rays(structure):
    scene = make_scene(structure)
    result = render(scene, dict(cost_rays="primary"))
    camera, _, _ = make_view()
    ys, xs = np.mgrid[0:H, 0:W]
    origins, directions = raylab.camera_rays(camera, np.column_stack([xs.ravel(), ys.ravel()]) + 0.5)
    per_ray = scene.intersect(origins, directions, tmin=camera["clip_start"], per_ray=True).per_ray
    for name in raylab.COUNTERS:
        expected = per_ray[name].reshape(H, W).astype(np.float32)
        assert np.array_equal(result.cost[name], expected), (structure, name)
    assert (result.cost["rays"] == 1).all()


def test_primary_cost_counts_only_the_camera_rays_of_every_sample():
    scene = make_scene()
    primary = render(scene, dict(cost_rays="primary", super_sampling=2))
    every = render(scene, dict(cost_rays="all", super_sampling=2))
    assert np.array_equal(primary.image, every.image) and primary.stats["rays"] == every.stats["rays"]
    assert (primary.cost["rays"] == 4).all()
    assert int(primary.cost["rays"].sum()) == primary.stats["rays_primary"]
    for name in raylab.COUNTERS:
        assert (every.cost[name] >= primary.cost[name]).all(), name
    # What "all" adds to each pixel is its shadow, reflection and refraction rays.
    secondary = every.stats["rays"] - every.stats["rays_primary"]
    assert secondary > 0 and int((every.cost["rays"] - primary.cost["rays"]).sum()) == secondary


def test_cost_rays_must_be_one_of_the_named_choices():
    with pytest.raises(ValueError, match=r"settings\['cost_rays'\] must be one of 'all', 'primary'"):
        render(make_scene(), dict(cost_rays="shadow"))
