"""OBJ files and paths the loader must refuse, with a ValueError naming the file and line, instead of
loading something else than they say (a NaN as 0, a missing coordinate as 0, an index wrapped round 2^32 onto
another vertex, another file), or reading what never ends (a device, a FIFO)."""
import os
import subprocess
import sys

import numpy as np
import pytest

import raylab
from conftest import ADDON, MESH_DIR, MESHES

TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"

# Line 5 of each file, after the good triangle; a face uses it so that a loader that reads it as
# zeros would make a plausible mesh of it.
BAD_VERTICES = {
    "NaN": ("v nan nan nan", "vertex coordinate 'nan' is not a finite number"),
    "infinity": ("v inf 0 0", "vertex coordinate 'inf' is not a finite number"),
    "letters": ("v a b c", "vertex coordinate 'a' is not a finite number"),
    "decimal comma": ("v 1,5 2 3", "vertex coordinate '1,5' is not a finite number"),
    "beyond float": ("v 0 1e39 0", "vertex coordinate '1e39' is not a finite number"),
    "two coordinates": ("v 1 0", "vertex has 2 coordinates, expected x y z"),
    "no coordinates": ("v ", "vertex has 0 coordinates, expected x y z"),
}


@pytest.mark.parametrize("case", BAD_VERTICES, ids=list(BAD_VERTICES))
@pytest.mark.parametrize("reader", ["load_mesh", "build_file"])
def test_a_bad_vertex_line_is_a_value_error_naming_file_and_line(tmp_path, case, reader):
    line, message = BAD_VERTICES[case]
    path = tmp_path / "bad.obj"
    path.write_text(TRIANGLE + line + "\nf 1 2 4\n")
    with pytest.raises(ValueError) as error:
        getattr(raylab, reader)(path)
    assert str(error.value) == f"{path}:5: {message}"


def test_a_directory_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="it is a directory"):
        raylab.load_mesh(tmp_path)
    with pytest.raises(ValueError, match="it is a directory"):
        raylab.build_file(str(tmp_path))


def test_a_path_with_a_nul_character_is_refused_not_cut_short(tmp_path):
    (tmp_path / "sphere.obj").write_text(TRIANGLE)
    for path in (f"{tmp_path}/sphere.obj\0garbage", f"{tmp_path}/sphere.obj\0garbage".encode()):
        with pytest.raises(ValueError, match="mesh path contains a NUL character"):
            raylab.load_mesh(path)
        with pytest.raises(ValueError, match="mesh path contains a NUL character"):
            raylab.build_file(path)


def test_a_face_beyond_the_vertices_names_the_file_and_line(tmp_path):
    path = tmp_path / "far.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(ValueError) as error:
        raylab.load_mesh(path)
    assert str(error.value) == f"{path}:4: face index '9' is past the last vertex: the file has 3"


# Each loaded as a triangle of vertices 1-3 (the index wrapped round 2^32) or named another vertex.
BAD_FACES = {
    "2^32 + 1": ("f 4294967297 2 3", "face index '4294967297' is past the last vertex: the file has 3"),
    "2^33 + 3": ("f 8589934595 1 2", "face index '8589934595' is past the last vertex: the file has 3"),
    "past int64": ("f 99999999999999999999 1 2", "face index '99999999999999999999' is past the last vertex: "
                   "the file has 3"),
    "2^31": ("f 2147483648 1 2", "face index '2147483648' is past the last vertex: the file has 3"),
    "-(2^32 - 1)": ("f 2 3 -4294967295", "face index '-4294967295' counts back before the first vertex: "
                    "3 vertices precede this line"),
    "zero": ("f 0 1 2", "face vertex '0' has an index 0: OBJ indices count from 1, or back from -1"),
    "two corners": ("f 1 2", "face has 2 vertices, expected at least 3"),
}


@pytest.mark.parametrize("case", BAD_FACES, ids=list(BAD_FACES))
def test_a_face_index_that_names_no_vertex_is_refused_as_written(tmp_path, case):
    face, message = BAD_FACES[case]
    path = tmp_path / "wrap.obj"
    path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 1 0\n{face}\n")
    with pytest.raises(ValueError) as error:
        raylab.load_mesh(path)
    assert str(error.value) == f"{path}:4: {message}"


def test_long_coordinates_load_their_exact_value(tmp_path):
    path = tmp_path / "long.obj"
    zeros = "0" * 400
    path.write_text(f"v 0.{zeros}1e400 0 0\nv 1{zeros}e-400 0 0\nv 0 1 0\nf 1 2 3\n")
    vertices, _ = raylab.load_mesh(path)
    assert vertices[0, 0] == np.float32(0.1) and vertices[1, 0] == np.float32(1.0)


@pytest.mark.parametrize("line, shown", [(b"v \xff\xfe 0 0", "vertex coordinate '\\xff\\xfe' is not a finite number"),
                                         (b"f 1 2 \xff", "face vertex '\\xff' is not v, v/vt, v//vn or v/vt/vn with "
                                                          "whole-number indices")], ids=["v", "f"])
def test_bytes_that_are_not_utf8_are_shown_escaped_with_file_and_line(tmp_path, line, shown):
    path = tmp_path / "bytes.obj"
    path.write_bytes(TRIANGLE.encode() + line + b"\n")
    with pytest.raises(ValueError) as error:
        raylab.load_mesh(path)
    assert str(error.value) == f"{path}:5: {shown}"


def test_a_device_is_refused_without_reading_it():
    # /dev/null first: a loader that reads devices stops here instead of filling the memory from /dev/zero.
    for device in ("/dev/null", "/dev/zero"):
        with pytest.raises(ValueError) as error:
            raylab.load_mesh(device)
        assert str(error.value) == f"cannot read mesh '{device}': it is a character device"


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path):
    fifo = tmp_path / "mesh.obj"
    os.mkfifo(fifo)
    # In a child process: a loader that opens the FIFO blocks until a writer comes.
    code = ("import sys, raylab\ntry:\n    raylab.load_mesh(sys.argv[1])\nexcept ValueError as e:\n    print(e)")
    done = subprocess.run([sys.executable, "-c", code, str(fifo)], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(ADDON)})
    assert done.stdout.strip() == f"cannot read mesh '{fifo}': it is a FIFO", done.stderr


def test_a_file_over_the_size_limit_is_refused_before_reading(tmp_path):
    path = tmp_path / "huge.obj"
    with open(path, "wb") as file:
        file.truncate(2**30 + 1)  # sparse: nothing is written
    with pytest.raises(ValueError) as error:
        raylab.load_mesh(path)
    assert str(error.value) == (f"cannot read mesh '{path}': it has 1073741825 bytes, more than the 1 GiB a mesh "
                                "file may have")


def test_quads_and_polygons_give_the_triangles_they_gave_before(tmp_path):
    # What tinyobjloader 1.0.6 (raylab's loader until issue 28) made of them: a quad split along its shorter
    # diagonal (the second one if equal), a larger convex polygon as a fan from its first corner.
    path = tmp_path / "polygons.obj"
    path.write_text("v 0 -1 0\nv 2 0 0\nv 0 1 0\nv -2 0 0\n"
                    "v 0 0 0\nv 2 -1 0\nv 4 0 0\nv 2 1 0\n"
                    "v 5 0 0\nv 6 0 0\nv 6 1 0\nv 5 1 0\n"
                    "v 0 0 0\nv 2 0 0\nv 3 2 0\nv 1 3 0\nv -1 2 0\n"
                    "v 1 0 0\nv 2 0 0\nv 3 1 0\nv 2 2 0\nv 1 2 0\nv 0 1 0\n"
                    "f 1 2 3 4\nf 5 6 7 8\nf 9 10 11 12\nf 13 14 15 16 17\nf 18 19 20 21 22 23\n")
    _, triangles = raylab.load_mesh(path)
    np.testing.assert_array_equal(triangles, [[0, 1, 2], [0, 2, 3], [4, 5, 7], [5, 6, 7], [8, 9, 11], [9, 10, 11],
                                              [12, 13, 14], [12, 14, 15], [12, 15, 16], [17, 18, 19], [17, 19, 20],
                                              [17, 20, 21], [17, 21, 22]])


def test_a_concave_polygon_is_covered_without_a_triangle_outside_it(tmp_path):
    # An L (area 3) whose first corner is opposite the notch: a fan from it would cover the notch too.
    path = tmp_path / "l.obj"
    path.write_text("v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\n")
    vertices, triangles = raylab.load_mesh(path)
    corners = vertices[triangles]
    areas = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])[:, 2] / 2
    assert len(triangles) == 4 and (areas > 0).all() and areas.sum() == 3


def test_a_thin_convex_polygon_gives_all_its_triangles(tmp_path):
    # tinyobjloader's ear clipping gave these five points on an arc one triangle of three.
    path = tmp_path / "arc.obj"
    path.write_text("v 4.039660 0.452483 2.897946\nv 4.039660 0.569742 2.820118\nv 4.039660 0.621916 2.794041\n"
                    "v 4.039660 0.661312 2.777324\nv 4.039660 1.150104 2.743497\nf 1 2 3 4 5\n")
    _, triangles = raylab.load_mesh(path)
    np.testing.assert_array_equal(triangles, [[0, 1, 2], [0, 2, 3], [0, 3, 4]])


def test_valid_files_still_load_polygons_negative_indices_and_attributes(tmp_path):
    path = tmp_path / "good.obj"
    path.write_bytes(b"# quad, pentagon, triangle\r\nmtllib none.mtl\r\no thing\r\n"
                     b"v 0 0 0\r\nv +1.0 0 0 1.0\r\n\tv 1 1 0\r\nv  0 1e0  0\r\nv -.5 0.5 -0\r\n"
                     b"vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvn 0 0 1\r\nusemtl none\r\ns off\r\n"
                     b"f 1/1/1 2/2/1 3/3/1 4/1/1\r\nf 1 2 3 4 5\r\nf -3//1 -2//1 -1//1\r\n")
    vertices, triangles = raylab.load_mesh(path)
    np.testing.assert_array_equal(vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [-0.5, 0.5, 0]])
    np.testing.assert_array_equal(triangles, [[0, 1, 3], [1, 2, 3], [0, 1, 2], [0, 2, 3], [0, 3, 4], [2, 3, 4]])


# The counts every shipped mesh had before the strict check (tinyobjloader alone).
SHIPPED = {"armadillo": (14587, 29170), "bunny": (3301, 6598), "bunny_hr": (29834, 59664),
           "dragon": (50000, 100000), "goathead": (2763, 5522), "koala": (49999, 99994),
           "plane_holes": (8519, 16747), "rod": (12, 20), "sphere": (642, 1280), "spot_low_resolution": (829, 1654),
           "teapot": (3644, 6320)}


def test_every_shipped_mesh_loads_with_its_counts():
    assert sorted(SHIPPED) == MESHES
    for name, (vertex_count, triangle_count) in SHIPPED.items():
        vertices, triangles = raylab.load_mesh(MESH_DIR / f"{name}.obj")
        assert (len(vertices), len(triangles)) == (vertex_count, triangle_count), name
