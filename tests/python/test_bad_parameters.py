"""Every argument of the Python API that is not an array: a wrong type or range is a short ValueError
naming the parameter and what it accepts, never pybind11's generic TypeError that prints every
argument (arrays included) and names none."""
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import raylab
from conftest import ADDON, MESH_DIR

VERTICES = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
TRIANGLES = np.array([[0, 1, 2]], np.uint32)
# Large enough that a message printing them would be long.
ORIGINS = np.zeros((500, 3), np.float32) + [0.2, 0.2, 1.0]
DIRECTIONS = np.zeros((500, 3), np.float32) + [0, 0, -1.0]
RAY = ([0.2, 0.2, 1.0], [0, 0, -1.0])


def structure():
    return raylab.build(VERTICES, TRIANGLES)


def scene():
    s = raylab.Scene()
    s.add_instance(s.add_mesh(VERTICES, TRIANGLES), np.eye(4))
    s.commit()
    return s


SETTINGS = {
    "max_depth beyond 32 bits": (dict(max_depth=2 ** 31), "max_depth must be an integer that fits in 32 bits, "
                                 "got 2147483648"),
    "max_depth float": (dict(max_depth=2.0), "max_depth must be an integer that fits in 32 bits, got 2.0"),
    "max_depth unknown word": (dict(max_depth="deep"), "max_depth must be 'auto' or an integer, got 'deep'"),
    "max_depth negative": (dict(max_depth=-1), "max_depth must be >= 0 or 'auto', got -1"),
    "leaf_size huge": (dict(leaf_size=10 ** 5000), "leaf_size must be an integer that fits in 32 bits, "
                       "got an integer of 16610 bits"),
    "leaf_size bool": (dict(leaf_size=True), "leaf_size must be an integer that fits in 32 bits, got True"),
    "structure None": (dict(structure=None), "structure must be a str: " + ", ".join(raylab.STRUCTURES[:-1]) +
                       f" or {raylab.STRUCTURES[-1]}, got None"),
    "triangle_test number": (dict(triangle_test=1), "triangle_test must be a str: watertight or moller_trumbore, "
                             "got 1"),
    "builder unknown": (dict(builder="best"), "unknown builder 'best': expected " + " or ".join(raylab.BUILDERS)),
    "builder number": (dict(builder=2), "builder must be a str: " + ", ".join(raylab.BUILDERS[:-1]) +
                       f" or {raylab.BUILDERS[-1]}, got 2"),
    "builder of a kind without one": (dict(structure="octree", builder="lbvh"),
                                      "builder 'lbvh' is not available for structure 'octree': it has one way to "
                                      "build (bvh take a builder)"),
    "memory_budget array": (dict(memory_budget=np.zeros(1000)), "memory_budget must be a whole number of bytes "
                            "or None, got a value of type numpy.ndarray"),
}

# Every public entry point that takes build settings, called with one bad keyword.
SETTINGS_CALLS = {
    "build": lambda **kw: raylab.build(VERTICES, TRIANGLES, **kw),
    "build_file": lambda **kw: raylab.build_file(MESH_DIR / "sphere.obj", **kw),
    "Scene": lambda **kw: raylab.Scene(**kw),
    "Scene.set_settings": lambda **kw: raylab.Scene().set_settings(**kw),
}


def assert_short_value_error(call, message):
    with pytest.raises(ValueError) as error:
        call()
    text = str(error.value)
    assert text == message
    assert len(text) < 300


@pytest.mark.parametrize("case", SETTINGS, ids=list(SETTINGS))
@pytest.mark.parametrize("entry", SETTINGS_CALLS, ids=list(SETTINGS_CALLS))
def test_a_bad_build_setting_names_the_parameter(entry, case):
    keywords, message = SETTINGS[case]
    assert_short_value_error(lambda: SETTINGS_CALLS[entry](**keywords), message)


THREADS = "threads must be None or an integer from 0 to 2147483647 (None or 0: all cores), got "
# (target, method, arguments, message) for the query parameters of structures and scenes.
QUERIES = {
    "intersect tmin None": (structure, "intersect", (ORIGINS, DIRECTIONS, None),
                            "tmin must be a real number, got None"),
    "intersect tmax array": (structure, "intersect", (ORIGINS, DIRECTIONS, 0.0, np.ones(500)),
                             "tmax must be a real number, got a value of type numpy.ndarray"),
    "intersect count str": (structure, "intersect", (ORIGINS, DIRECTIONS, 0.0, 1.0, "yes"),
                            "count must be True or False, got 'yes'"),
    "occluded tmin str": (structure, "occluded", (ORIGINS, DIRECTIONS, "0"), "tmin must be a real number, got '0'"),
    "occluded count None": (structure, "occluded", (ORIGINS, DIRECTIONS, 0.0, 1.0, None),
                            "count must be True or False, got None"),
    "story tmax None": (structure, "story", RAY + (0.0, None), "tmax must be a real number, got None"),
    "scene intersect tmin": (scene, "intersect", (ORIGINS, DIRECTIONS, [0.0]), "tmin must be a real number, "
                             "got a value of type list"),
    "scene occluded count": (scene, "occluded", (ORIGINS, DIRECTIONS, 0.0, 1.0, 2),
                             "count must be True or False, got 2"),
    "intersect threads -1": (structure, "intersect", (ORIGINS, DIRECTIONS, 0.0, 1.0, False, -1),
                             THREADS + "-1"),
    "intersect threads float": (structure, "intersect", (ORIGINS, DIRECTIONS, 0.0, 1.0, False, 2.0),
                                THREADS + "2.0"),
    "occluded threads str": (structure, "occluded", (ORIGINS, DIRECTIONS, 0.0, 1.0, False, "2"),
                             THREADS + "'2'"),
    "statuses threads bool": (structure, "statuses", (ORIGINS, DIRECTIONS, 0.0, 1.0, True), THREADS + "True"),
    "scene intersect threads -3": (scene, "intersect", (ORIGINS, DIRECTIONS, 0.0, 1.0, False, -3),
                                   THREADS + "-3"),
    "split_costs numpy -1": (structure, "split_costs", (np.int32(-1),),
                             "node must be an integer from 0 to 4294967295, got -1"),
    "scene occluded threads 2**40": (scene, "occluded", (ORIGINS, DIRECTIONS, 0.0, 1.0, False, 2 ** 40),
                                     THREADS + "1099511627776"),
}


@pytest.mark.parametrize("case", QUERIES, ids=list(QUERIES))
def test_a_bad_query_parameter_names_it(case):
    target, method, arguments, message = QUERIES[case]
    query = getattr(target(), method)
    assert_short_value_error(lambda: query(*arguments), message)


BIG = 2 ** 70
SCENE_CALLS = {
    "add_instance mesh 2**70": (lambda s: s.add_instance(BIG, np.eye(4)),
                                f"unknown mesh id {BIG}: the scene has 1 mesh"),
    "add_instance mesh None": (lambda s: s.add_instance(None, np.eye(4)), "mesh must be an integer id, got None"),
    "add_instance mesh float": (lambda s: s.add_instance(0.0, np.eye(4)), "mesh must be an integer id, got 0.0"),
    "add_instance material 2**40": (lambda s: s.add_instance(0, np.eye(4), 2 ** 40),
                                    "material must be a non-negative index that fits in 32 bits, got 1099511627776"),
    "add_instance material -1": (lambda s: s.add_instance(0, np.eye(4), -1),
                                 "material must be a non-negative index that fits in 32 bits, got -1"),
    "set_transform instance 2**70": (lambda s: s.set_transform(BIG, np.eye(4)),
                                     f"unknown instance id {BIG}: the scene has 1 instance"),
    "set_transform instance str": (lambda s: s.set_transform("0", np.eye(4)),
                                   "instance must be an integer id, got '0'"),
    "replace_mesh mesh 2**70": (lambda s: s.replace_mesh(BIG, VERTICES, TRIANGLES),
                                f"unknown mesh id {BIG}: the scene has 1 mesh"),
    "replace_mesh mesh array": (lambda s: s.replace_mesh(np.zeros(500), VERTICES, TRIANGLES),
                                "mesh must be an integer id, got a value of type numpy.ndarray"),
}


@pytest.mark.parametrize("case", SCENE_CALLS, ids=list(SCENE_CALLS))
def test_a_bad_scene_id_names_the_parameter(case):
    call, message = SCENE_CALLS[case]
    s = scene()
    assert_short_value_error(lambda: call(s), message)


@pytest.mark.parametrize("reader", ["load_mesh", "build_file"])
@pytest.mark.parametrize("path", [None, 3, ["sphere.obj"]], ids=["None", "int", "list"])
def test_a_path_that_is_no_path_names_the_parameter(reader, path):
    with pytest.raises(ValueError) as error:
        getattr(raylab, reader)(path)
    assert str(error.value).startswith("path must be a str, bytes or os.PathLike, got ")
    assert len(str(error.value)) < 300


RENDER_SETTINGS = {
    "threads beyond 32 bits": (dict(threads=2 ** 40),
                               "settings['threads'] must be an integer that fits in 32 bits, got 1099511627776"),
    "tile_size float": (dict(tile_size=16.0), "settings['tile_size'] must be an integer that fits in 32 bits, "
                        "got 16.0"),
    "shadows array": (dict(shadows=np.zeros(500)),
                      "settings['shadows'] must be True or False, got a value of type numpy.ndarray"),
    "fixed_epsilon str": (dict(fixed_epsilon="1e-4"), "settings['fixed_epsilon'] must be a real number, got '1e-4'"),
    "max_depth renamed": (dict(max_depth=2), "settings: max_depth is now max_recursion (the octree's max_depth is a "
                          "build setting)"),
    "max_recursion negative": (dict(max_recursion=-1), "settings: max_recursion must be 0 to 64, got -1"),
}
CAMERA = dict(matrix_world=np.eye(4), resolution_x=4, resolution_y=4)


@pytest.mark.parametrize("case", RENDER_SETTINGS, ids=list(RENDER_SETTINGS))
def test_a_bad_render_setting_names_it(case):
    settings, message = RENDER_SETTINGS[case]
    s = scene()
    assert_short_value_error(lambda: raylab.render(s, CAMERA, [], [{}], settings), message)


def test_a_bad_camera_choice_does_not_print_an_array():
    camera = dict(CAMERA, type=np.zeros(500))
    assert_short_value_error(lambda: raylab.render(scene(), camera, [], [{}]),
                             "camera['type'] must be one of 'PERSP', 'ORTHO', got a value of type numpy.ndarray")


def test_good_parameters_of_other_types_still_work():
    """numpy scalars, 0 and 1 for flags, paths as str, bytes or pathlib.Path."""
    s = raylab.build(VERTICES, TRIANGLES, max_depth=np.int64(3), leaf_size=np.uint8(4),
                     memory_budget=np.int64(10 ** 8))
    assert (s.max_depth, s.leaf_size) == (3, 4)
    hits = s.intersect(ORIGINS, DIRECTIONS, np.float32(0.5), 2, count=1)
    assert hits.hit.all() and hits.stats["rays"] == 500
    assert not s.occluded(ORIGINS, DIRECTIONS, 0, np.float64(0.5), np.False_).hit.any()
    sc = scene()
    assert sc.add_instance(np.int32(0), np.eye(4), np.uint16(1)) == 1
    sphere = MESH_DIR / "sphere.obj"
    for path in (sphere, str(sphere), bytes(sphere), pathlib.PurePosixPath(sphere)):
        assert raylab.load_mesh(path)[0].shape == (642, 3)


# Every entry that converts a float64 array to float32: under `-W error` numpy's overflow warning fails
# the conversion, which was dereferenced as a null array (a segmentation fault). Run in a child.
HUGE = "(np.zeros((4, 3)) + 1e300)"
CONVERSIONS = {
    "intersect": ("origins", f"st.intersect({HUGE}, np.float32([0, 0, -1]))"),
    "occluded": ("directions", f"st.occluded(np.float32([0, 0, 1]), {HUGE})"),
    "statuses": ("origins", f"st.statuses({HUGE}, np.float32([0, 0, -1]))"),
    "story": ("origin", "st.story(np.zeros(3) + 1e300, np.float32([0, 0, -1]))"),
    "build": ("vertices", f"raylab.build({HUGE}[:3], T)"),
    "refit": ("vertices", f"st.refit({HUGE}[:3])"),
    "add_mesh": ("vertices", f"raylab.Scene().add_mesh({HUGE}[:3], T)"),
    "refit_mesh": ("vertices", f"sc.refit_mesh(m, {HUGE}[:3])"),
    "replace_mesh": ("vertices", f"sc.replace_mesh(m, {HUGE}[:3], T)"),
    "add_instance": ("matrix", "sc.add_instance(m, np.eye(4) * 1e300)"),
    "scene intersect": ("origins", f"sc.commit(); sc.intersect({HUGE}, np.float32([0, 0, -1]))"),
}


@pytest.mark.parametrize("case", CONVERSIONS)
def test_a_float64_array_that_cannot_become_float32_is_a_value_error_naming_it(case):
    name, call = CONVERSIONS[case]
    code = ("import numpy as np, raylab\n"
            "V = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]); T = np.uint32([[0, 1, 2]])\n"
            "st = raylab.build(V, T); sc = raylab.Scene(); m = sc.add_mesh(V, T)\n"
            f"try:\n    {call}\nexcept ValueError as e:\n    print(e, '|', type(e.__cause__).__name__)\n")
    child = subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, timeout=120,
                           env={**os.environ, "PYTHONPATH": str(ADDON)})
    assert (child.returncode, child.stdout.strip()) == (0, f"{name} cannot be converted to float32 | RuntimeWarning"), \
        child.stderr[-2000:]


def test_a_complex_matrix_is_refused():
    s = raylab.Scene()
    mesh = s.add_mesh(VERTICES, TRIANGLES)
    with pytest.raises(ValueError, match=r"matrix must be a \(4, 4\) array of real numbers"):
        s.add_instance(mesh, np.eye(4, dtype=np.complex64))
