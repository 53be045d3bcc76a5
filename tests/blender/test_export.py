"""Scene export: raylab sees the scene Blender sees (modifiers, transforms, instances), with shared meshes.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import math

import bpy
import numpy as np
import pytest

import raylab
from raylab.blender import compat, scene_export

WIDTH, HEIGHT = 96, 72


def clear_scene():
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):   # also those only in unlinked collections: names stay as created
        bpy.data.objects.remove(obj)
    for collection in list(bpy.data.collections):
        bpy.data.collections.remove(collection)
    for mesh in list(bpy.data.meshes):   # new primitives take their object's name from a free mesh name
        bpy.data.meshes.remove(mesh)
    return scene


def add_camera(scene, location, rotation):
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = location, rotation
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = WIDTH, HEIGHT, 100
    return camera


@pytest.fixture
def busy_scene():
    """Rotated and scaled objects, a subdivision and an array modifier, linked duplicates, collection instances."""
    scene = clear_scene()
    bpy.ops.mesh.primitive_monkey_add(location=(-2.2, 0.5, 0.3), rotation=(0.3, 0.2, 0.9))
    monkey = bpy.context.object
    monkey.scale = (1.0, 1.4, 0.8)
    monkey.modifiers.new("Subdivision", 'SUBSURF').levels = 1

    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.6, 2.0, -1.0), rotation=(0.0, 0.4, 0.5))
    bars = bpy.context.object
    bars.modifiers.new("Array", 'ARRAY').count = 3

    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.7, location=(1.6, -0.6, 0.8))
    ball = bpy.context.object
    twin = ball.copy()   # a linked duplicate: same mesh datablock
    twin.location = (2.4, 1.0, -0.6)
    twin.scale = (0.5, 0.5, 1.5)
    scene.collection.objects.link(twin)

    props = bpy.data.collections.new("Props")   # not linked to the scene: seen only through its instances
    bpy.ops.mesh.primitive_torus_add(major_radius=0.5, minor_radius=0.15)
    torus = bpy.context.object
    for collection in list(torus.users_collection):
        collection.objects.unlink(torus)
    props.objects.link(torus)
    for name, location in (("Props A", (-0.6, -1.2, -1.2)), ("Props B", (-1.0, 1.5, 1.6))):
        empty = bpy.data.objects.new(name, None)
        empty.instance_type = 'COLLECTION'
        empty.instance_collection = props
        empty.location = location
        empty.rotation_euler = (0.7, 0.0, 0.3)
        scene.collection.objects.link(empty)

    add_camera(scene, location=(0.3, -9.0, 1.2), rotation=(math.radians(84.0), 0.0, math.radians(2.0)))
    return scene


def blender_camera_rays(scene):
    """(H*W,3) origins and unit directions through the pixel centres, row 0 at the top, from view_frame:
    perspective rays leave the camera, orthographic rays leave the camera plane along its -Z."""
    camera = scene.camera
    matrix = np.array(camera.matrix_world.normalized())
    top_right, _, bottom_left, top_left = [np.array(corner) for corner in camera.data.view_frame(scene=scene)]
    u = (np.arange(WIDTH) + 0.5) / WIDTH
    v = (np.arange(HEIGHT) + 0.5) / HEIGHT
    local = (top_left + u[None, :, None] * (top_right - top_left)
             + v[:, None, None] * (bottom_left - top_left)).reshape(-1, 3)
    if camera.data.type == 'ORTHO':
        local_origins = local * [1.0, 1.0, 0.0]
        local_directions = np.tile([0.0, 0.0, -1.0], (len(local), 1))
    else:
        local_origins = np.zeros_like(local)
        local_directions = local
    origins = local_origins @ matrix[:3, :3].T + matrix[:3, 3]
    directions = local_directions @ matrix[:3, :3].T
    return origins, directions / np.linalg.norm(directions, axis=1, keepdims=True)


def blender_ray_cast(scene, depsgraph):
    """Blender's own closest hit per pixel: (object name or '', distance or inf) maps."""
    names = np.full(WIDTH * HEIGHT, "", dtype=object)
    distances = np.full(WIDTH * HEIGHT, np.inf)
    for k, (origin, direction) in enumerate(zip(*blender_camera_rays(scene))):
        hit, location, _, _, obj, _ = scene.ray_cast(depsgraph, origin, direction)
        if hit:
            names[k] = obj.original.name
            distances[k] = np.linalg.norm(np.array(location) - origin)
    return names.reshape(HEIGHT, WIDTH), distances.reshape(HEIGHT, WIDTH)


def silhouette_pixels(*name_maps):
    """Pixels with a 4-neighbour that shows another object (or background) in any of the maps."""
    edge = np.zeros(name_maps[0].shape, bool)
    for names in name_maps:
        differs_down = names[1:, :] != names[:-1, :]
        differs_right = names[:, 1:] != names[:, :-1]
        edge[1:, :] |= differs_down
        edge[:-1, :] |= differs_down
        edge[:, 1:] |= differs_right
        edge[:, :-1] |= differs_right
    return edge


CAMERAS = {
    "perspective": {},
    "perspective, vertical sensor fit, shifted, wide pixels":
        dict(sensor_fit='VERTICAL', shift_x=0.08, shift_y=-0.05, lens=38.0, pixel_aspect_x=1.5),
    "orthographic": dict(type='ORTHO', ortho_scale=7.5, shift_x=0.05),
}


@pytest.mark.parametrize("camera_settings", CAMERAS.values(), ids=CAMERAS.keys())
def test_raylab_sees_what_blender_ray_cast_sees(busy_scene, camera_settings):
    camera = busy_scene.camera.data
    for name, value in camera_settings.items():
        setattr(busy_scene.render if name.startswith("pixel_aspect") else camera, name, value)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    exported = scene_export.export_scene(depsgraph)
    raylab_scene, objects = scene_export.build_scene(exported, structure="bvh")
    settings = scene_export.render_settings(exported, busy_scene.raylab_render, super_sampling=1)
    result = raylab.render(raylab_scene, exported.camera, exported.lights, exported.materials, settings)
    assert result.instance.shape == (HEIGHT, WIDTH)

    lookup = np.vectorize(lambda i: objects.get(int(i), ""), otypes=[object])
    raylab_names = lookup(result.instance)
    blender_names, blender_distances = blender_ray_cast(busy_scene, depsgraph)
    assert {"Suzanne", "Cube", "Icosphere", "Icosphere.001", "Torus"} <= set(blender_names.ravel())

    both_miss = (raylab_names == "") & (blender_names == "")
    same_hit = (raylab_names == blender_names) & np.isclose(result.distance, blender_distances,
                                                            rtol=1e-3, atol=1e-4)
    disagree = ~(both_miss | same_hit)
    on_silhouette = silhouette_pixels(raylab_names, blender_names)
    print(f"\n{int(disagree.sum())} of {disagree.size} pixels differ from Blender's ray_cast, "
          f"{int((disagree & on_silhouette).sum())} of them on silhouette edges")
    assert disagree.mean() <= 0.001
    assert not (disagree & ~on_silhouette).any(), np.argwhere(disagree & ~on_silhouette)[:10]


def test_instances_share_one_mesh_and_modifiers_are_applied(busy_scene):
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    by_object = {}
    for instance in exported.instances:
        by_object.setdefault(instance.object_name, []).append(instance.mesh)
    # The two collection instances of the torus, and the two objects of one icosphere mesh, share a mesh.
    assert len(by_object["Torus"]) == 2 and len(set(by_object["Torus"])) == 1
    assert by_object["Icosphere"] == by_object["Icosphere.001"]
    assert len(exported.meshes) == 4 < len(exported.instances) == 6
    monkey_vertices, monkey_triangles = exported.meshes[by_object["Suzanne"][0]]
    assert len(monkey_triangles) > 2 * len(bpy.data.objects["Suzanne"].data.loop_triangles)
    bars_vertices, _ = exported.meshes[by_object["Cube"][0]]
    assert len(bars_vertices) == 3 * len(bpy.data.objects["Cube"].data.vertices)


def test_text_is_exported_as_blender_meshes_it(busy_scene):
    # scene.ray_cast does not see curves and text, so this checks the triangles instead of pixels.
    bpy.ops.object.text_add()
    text = bpy.context.object
    text.data.extrude = 0.08
    depsgraph = bpy.context.evaluated_depsgraph_get()
    exported = scene_export.export_scene(depsgraph)
    [mesh] = [i.mesh for i in exported.instances if i.object_name == "Text"]
    blender_mesh = text.evaluated_get(depsgraph).to_mesh()
    blender_mesh.calc_loop_triangles()
    assert len(exported.meshes[mesh][1]) == len(blender_mesh.loop_triangles) > 0
    text.evaluated_get(depsgraph).to_mesh_clear()


def test_principled_material_and_object_colour_fallback(busy_scene):
    material = bpy.data.materials.new("Brass")
    bsdf = compat.use_node_tree(material).nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.9, 0.6, 0.2, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.2
    bsdf.inputs["IOR"].default_value = 1.5
    bpy.data.objects["Suzanne"].data.materials.append(material)
    bpy.data.objects["Cube"].color = (0.1, 0.8, 0.3, 1.0)

    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    material_of = {i.object_name: exported.materials[i.material] for i in exported.instances}
    brass = material_of["Suzanne"]
    assert brass["diffuse"] == pytest.approx((0.9, 0.6, 0.2))
    assert brass["metallic"] == 1.0 and brass["ior"] == pytest.approx(1.5)
    assert brass["shininess"] > material_of["Icosphere"]["shininess"]   # smoother: tighter highlight
    assert material_of["Cube"]["diffuse"] == pytest.approx((0.1, 0.8, 0.3))


def test_shininess_follows_roughness_within_its_range():
    values = [scene_export.shininess_from_roughness(r) for r in (0.0, 0.1, 0.3, 0.5, 1.0)]
    assert values == sorted(values, reverse=True)
    assert values[0] == 1000.0 and values[-1] == 1.0


def test_unrenderable_scenes_raise_a_clear_export_error():
    scene = clear_scene()
    with pytest.raises(scene_export.ExportError, match="no active camera"):
        scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    add_camera(scene, location=(0.0, -5.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0))
    with pytest.raises(scene_export.ExportError, match="no visible mesh"):
        scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    bpy.ops.mesh.primitive_plane_add()
    bpy.context.object.data.vertices[0].co = (math.nan, 0.0, 0.0)
    with pytest.raises(scene_export.ExportError, match="'Plane'.*NaN"):
        scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
