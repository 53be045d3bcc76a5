"""raylab's cost passes inside Blender: the View Layer's checkboxes register the passes (the compositor
and the pass menu see them), an F12 render writes them into a multilayer EXR, and their values are the
API's own counts of the same rays; the heat pass is those counts in raylab.heat_map's colours on the
stated scale, with its legend."""
import os
import tempfile

import bpy
import numpy as np
import pytest

import raylab
from raylab import _raylab_images
from raylab.blender import build_settings, compat, cost_passes, default_scene, scene_export

RESOLUTION = (60, 45)


@pytest.fixture
def demo_scene():
    scene = bpy.context.scene
    default_scene.build_default_scene(scene, resolution=RESOLUTION)
    scene.render.engine = 'RAYLAB'
    scene.raylab_render.structure = "bvh"
    scene.raylab_render.super_sampling = 1
    passes = scene.view_layers[0].raylab_passes
    for name in raylab.COST_PASSES:
        setattr(passes, cost_passes.use_property(name), False)
    passes.cost_rays = "all"
    passes.use_heat = False
    return scene


def enable(scene, names, cost_rays="all"):
    passes = scene.view_layers[0].raylab_passes
    for name in names:
        setattr(passes, cost_passes.use_property(name), True)
    passes.cost_rays = cost_rays


# 5.x writes only Combined into a render's multilayer EXR output (Cycles' passes too, 5.2.2): there the
# passes are read as the engine filled them, through compat.set_pass_pixels, the one door to a pass.
OUTPUT_FILE_HAS_PASSES = bpy.app.version < (5, 0)


def render_exr(scene):
    """F12 with multilayer EXR output written to disk: {channel name: (H, W) float32, row 0 the top}."""
    filled = {}
    fill = compat.set_pass_pixels

    def spy(render_pass, pixels):
        filled[render_pass.name] = (np.asarray(pixels, np.float32).reshape(
            scene.render.resolution_y, scene.render.resolution_x, -1)[::-1], render_pass.channels)
        fill(render_pass, pixels)

    with tempfile.TemporaryDirectory(prefix="raylab_passes_") as folder:
        path = os.path.join(folder, "render.exr")
        compat.set_file_format(scene.render.image_settings, 'OPEN_EXR_MULTILAYER')
        scene.render.image_settings.color_depth = '32'
        scene.render.filepath = path
        compat.set_pass_pixels = spy
        try:
            bpy.ops.render.render(write_still=True)
        finally:
            compat.set_pass_pixels = fill
        channels = _raylab_images.read_channels(path)
    layer = scene.view_layers[0].name
    assert f"{layer}.Combined.R" in channels
    if not OUTPUT_FILE_HAS_PASSES:
        for name, (pixels, count) in filled.items():
            ids = cost_passes.CHANNEL_ID if count == 1 else "RGBA"
            for index, id_ in enumerate(ids):
                channels.setdefault(f"{layer}.{name}.{id_}", pixels[:, :, index])
    return channels


def channel(scene, pass_name):
    return f"{scene.view_layers[0].name}.{pass_name}.{cost_passes.CHANNEL_ID}"


def api_counts(scene):
    """The API's per-ray counts of every pixel centre's camera ray, on the scene the render engine builds."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    exported = scene_export.export_scene(depsgraph)
    props = scene.raylab_render
    model, _ = scene_export.build_scene(exported, **build_settings.build_kwargs(props))
    width, height = raylab.image_size(exported.camera)
    ys, xs = np.mgrid[0:height, 0:width]
    origins, directions = raylab.camera_rays(exported.camera, np.column_stack([xs.ravel(), ys.ravel()]) + 0.5)
    hits = model.intersect(origins, directions, tmin=exported.camera["clip_start"], per_ray=True)
    return {name: values.reshape(height, width) for name, values in hits.per_ray.items()}


def render_layers_node(scene, view_layer):
    """A Render Layers node of a compositor tree made for asking; the caller removes the tree again
    (compat.remove_compositor) before rendering: 5.2 aborts a render whose compositor group has no output."""
    node = compat.render_layers_node(scene)
    node.layer = view_layer.name
    return node


def outputs(node):
    return {output.name for output in node.outputs if output.enabled}


def render_layer_outputs(scene):
    """The outputs the compositor's Render Layers node offers: what the first View Layer registered."""
    try:
        return outputs(render_layers_node(scene, scene.view_layers[0]))
    finally:
        compat.remove_compositor(scene)


def test_the_view_layer_registers_the_passes_it_enables(demo_scene):
    first, second = raylab.COST_PASSES[:2]
    assert not set(raylab.COST_PASSES) & render_layer_outputs(demo_scene)
    enable(demo_scene, [first, second])
    assert render_layer_outputs(demo_scene) & set(raylab.COST_PASSES) == {first, second}
    setattr(demo_scene.view_layers[0].raylab_passes, cost_passes.use_property(first), False)
    assert render_layer_outputs(demo_scene) & set(raylab.COST_PASSES) == {second}


def test_each_view_layer_delivers_the_passes_it_enables(demo_scene):
    first = demo_scene.view_layers[0]
    second = demo_scene.view_layers.new("Costs")
    try:
        node = render_layers_node(demo_scene, second)
        # A checkbox of the second view layer (not the window's) changes that layer's passes alone.
        setattr(second.raylab_passes, cost_passes.use_property(raylab.COST_PASSES[0]), True)
        assert raylab.COST_PASSES[0] in outputs(node)
        assert raylab.COST_PASSES[0] not in outputs(render_layers_node(demo_scene, first))
    finally:
        compat.remove_compositor(demo_scene)
        demo_scene.view_layers.remove(second)


def test_a_render_without_cost_passes_writes_none(demo_scene):
    channels = render_exr(demo_scene)
    assert f"{demo_scene.view_layers[0].name}.Combined.R" in channels
    assert not [name for name in channels if "raylab" in name]


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_primary_passes_in_the_exr_equal_the_api_counts_pixel_by_pixel(demo_scene, structure):
    demo_scene.raylab_render.structure = structure
    enable(demo_scene, raylab.COST_PASSES, cost_rays="primary")
    channels = render_exr(demo_scene)
    expected = api_counts(demo_scene)
    for name, info in raylab.COST_PASS_INFO.items():
        values = channels[channel(demo_scene, name)]
        assert values.shape == (RESOLUTION[1], RESOLUTION[0])
        assert np.array_equal(values, expected[info["counter"]].astype(np.float32)), (structure, name)
    assert expected["triangle_tests"].max() > 0


def test_all_ray_passes_add_up_to_the_renders_totals(demo_scene):
    demo_scene.raylab_render.super_sampling = 2
    enable(demo_scene, raylab.COST_PASSES, cost_rays="all")
    channels = render_exr(demo_scene)
    record = demo_scene["raylab_last_render"]
    assert record["rays"] > record["rays_primary"]  # shadow rays are in the passes too
    for name, info in raylab.COST_PASS_INFO.items():
        total = channels[channel(demo_scene, name)].sum(dtype=np.float64)
        assert total == record[info["counter"]], name


def heat_channels(scene, channels):
    """The heat pass from the EXR as (H, W, 4), row 0 the top."""
    layer = scene.view_layers[0].name
    return np.stack([channels[f"{layer}.{cost_passes.HEAT_PASS}.{c}"] for c in "RGBA"], axis=-1)


def enable_heat(scene, pass_name, maximum, legend):
    passes = scene.view_layers[0].raylab_passes
    passes.use_heat = True
    passes.heat_pass = pass_name
    passes.heat_maximum = maximum
    passes.heat_legend = legend
    passes.cost_rays = "primary"


@pytest.mark.parametrize("structure", ["none", "bvh"])
def test_the_heat_pass_is_the_counts_in_false_colour_on_the_stated_scale(demo_scene, structure):
    demo_scene.raylab_render.structure = structure
    triangles = next(name for name, info in raylab.COST_PASS_INFO.items() if info["counter"] == "triangle_tests")
    enable_heat(demo_scene, triangles, 500.0, legend=True)  # 60 x 45: too small for the legend
    assert cost_passes.HEAT_PASS in render_layer_outputs(demo_scene)
    heat = heat_channels(demo_scene, render_exr(demo_scene))
    expected = raylab.heat_map(api_counts(demo_scene)["triangle_tests"], 500.0)
    assert np.array_equal(heat, expected)
    scale = raylab.heat_scale_text("Triangle tests", 500.0)
    assert demo_scene["raylab_last_render"]["heat_scale"] == scale


def test_the_heat_pass_carries_its_legend_in_its_bottom_rows(demo_scene):
    demo_scene.render.resolution_x, demo_scene.render.resolution_y = 160, 120
    nodes = next(name for name, info in raylab.COST_PASS_INFO.items() if info["counter"] == "nodes_visited")
    enable_heat(demo_scene, nodes, 40.0, legend=True)
    heat = heat_channels(demo_scene, render_exr(demo_scene))
    legend = raylab.heat_legend(40.0, width=160)
    expected = raylab.heat_map(api_counts(demo_scene)["nodes_visited"], 40.0)
    assert np.array_equal(heat[-len(legend):], legend)
    assert np.array_equal(heat[:-len(legend)], expected[:-len(legend)])


@pytest.mark.parametrize("space", sorted(compat.REC709_TO))
def test_the_heat_pass_keeps_its_colours_in_the_files_working_space(demo_scene, space):
    """5.0+: a file may work in Rec.2020 or ACEScg; the heat map's colours (Rec.709) are converted, so the
    pass shows the same colours whatever the working space. Releases before 5.0 work in Rec.709 only."""
    colorspace = getattr(bpy.data, "colorspace", None)
    if colorspace is None:
        assert compat.working_space() == "Linear Rec.709"
        if space != "Linear Rec.709":
            return  # no other space to choose on this release: nothing to convert
    else:  # the file's setting, as File > Color Management would change it (its colours left as they are)
        if compat.working_space() != space:  # the operator cancels a change to the space already set
            assert bpy.ops.wm.set_working_color_space(working_space=space, convert_colors=False) == {'FINISHED'}
        assert compat.working_space() == space
    try:
        triangles = next(name for name, info in raylab.COST_PASS_INFO.items() if info["counter"] == "triangle_tests")
        enable_heat(demo_scene, triangles, 500.0, legend=False)
        heat = heat_channels(demo_scene, render_exr(demo_scene))
        expected = raylab.heat_map(api_counts(demo_scene)["triangle_tests"], 500.0)
        matrix = compat.REC709_TO[space]
        if matrix is not None:
            expected[..., :3] = expected[..., :3] @ matrix.T.astype(np.float32)
        assert np.allclose(heat, expected, atol=1e-6)
        same = np.array_equal(heat, raylab.heat_map(api_counts(demo_scene)["triangle_tests"], 500.0))
        assert (matrix is None) == same
    finally:
        if colorspace is not None and compat.working_space() != "Linear Rec.709":
            bpy.ops.wm.set_working_color_space(working_space="Linear Rec.709", convert_colors=False)


@pytest.fixture
def level_scene():
    """A level's scene as a student opens it (a new scene: its View Layer's raylab passes at their
    defaults), rendered with raylab; removed afterwards."""
    from raylab.blender import levels
    before = bpy.context.window.scene
    scene = levels.open_level(bpy.context, "where_work_goes")
    scene.render.engine = 'RAYLAB'
    yield scene
    bpy.context.window.scene = before
    levels._remove_scene(scene)


def test_the_heat_pass_by_default_shows_the_scenes_triangle_tests_in_a_spread_of_colours(level_scene):
    """Issue 27: ticking Heat alone used to give a black picture (rays per pixel, one or two, on 0-100)."""
    passes = level_scene.view_layers[0].raylab_passes
    passes.use_heat = True  # the one thing the student does
    triangles = raylab.COST_PASS_INFO[passes.heat_pass]
    assert triangles["counter"] == "triangle_tests"
    setattr(passes, cost_passes.use_property(passes.heat_pass), True)  # the counts, to check the colours by
    channels = render_exr(level_scene)
    layer = level_scene.view_layers[0].name
    counts = channels[f"{layer}.{passes.heat_pass}.{cost_passes.CHANNEL_ID}"]
    heat = heat_channels(level_scene, channels)
    height = heat.shape[0] - len(raylab.heat_legend(1.0, width=heat.shape[1]))  # the legend's rows
    picture, counts = heat[:height, :, :3], counts[:height]
    working = counts > 0
    assert working.mean() > 0.1, "the level's meshes cover part of the picture"
    # Not black: the pixels that did work are drawn across the colour map (as the display shows them), the
    # hardest near its top. Rays on 0-100, the old default, left them all under 0.08.
    brightness = (picture.max(axis=2)[working]) ** (1 / 2.2)
    assert np.median(brightness) > 0.2 and np.percentile(brightness, 95) > 0.8
    assert len(np.unique(np.round(picture[working], 3), axis=0)) > 30, "a spread of colours, not a silhouette"
    # The scale is stated, names the triangle tests and is the one the colours were drawn on.
    maximum = cost_passes.automatic_maximum(counts)
    assert 1 < maximum < counts.max() * 1.5
    assert np.array_equal(heat[:height], raylab.heat_map(counts, maximum)[:height])
    scale = level_scene["raylab_last_render"]["heat_scale"]
    assert scale.startswith(raylab.heat_scale_text("Triangle tests", maximum)) and "automatic" in scale


def test_a_maximum_the_user_sets_is_kept(demo_scene):
    passes = demo_scene.view_layers[0].raylab_passes
    passes.heat_maximum_auto = True
    passes.heat_maximum = 250.0  # typed into the panel
    assert not passes.heat_maximum_auto
    enable_heat(demo_scene, passes.heat_pass, 250.0, legend=False)
    heat = heat_channels(demo_scene, render_exr(demo_scene))
    assert np.array_equal(heat, raylab.heat_map(api_counts(demo_scene)["triangle_tests"], 250.0))
    assert demo_scene["raylab_last_render"]["heat_scale"] == raylab.heat_scale_text("Triangle tests", 250.0)


def test_the_automatic_maximum_is_a_round_number_over_nearly_every_working_pixel():
    counts = np.zeros((50, 40), np.float32)
    counts[10:30, 5:35] = np.arange(600).reshape(20, 30) % 73 + 1  # 1 to 73 spread out
    counts[0, 0] = 5000  # one hot pixel does not set the scale
    maximum = cost_passes.automatic_maximum(counts)
    assert maximum == 80
    assert (counts[counts > 0] <= maximum).mean() >= cost_passes.AUTO_PERCENTILE / 100
    assert cost_passes.automatic_maximum(np.zeros((4, 4))) == 1.0
    assert [cost_passes.round_up(v) for v in (0.3, 1, 7, 12, 101, 2600)] == [0.3, 1, 8, 15, 150, 3000]
