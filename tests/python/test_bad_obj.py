"""OBJ files and paths the loader must refuse, with a ValueError naming the file and line, instead of
loading something else than they say (a NaN as 0, a missing coordinate as 0, another file)."""
import numpy as np
import pytest

import raylab
from conftest import MESH_DIR, MESHES

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


def test_a_face_beyond_the_vertices_names_the_file(tmp_path):
    path = tmp_path / "far.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(ValueError) as error:
        raylab.load_mesh(path)
    assert str(error.value).startswith(f"mesh '{path}': triangle 0 refers to vertex 8")


def test_valid_files_still_load_polygons_negative_indices_and_attributes(tmp_path):
    path = tmp_path / "good.obj"
    path.write_bytes(b"# quad, pentagon, triangle\r\nmtllib none.mtl\r\no thing\r\n"
                     b"v 0 0 0\r\nv +1.0 0 0 1.0\r\n\tv 1 1 0\r\nv  0 1e0  0\r\nv -.5 0.5 -0\r\n"
                     b"vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvn 0 0 1\r\nusemtl none\r\ns off\r\n"
                     b"f 1/1/1 2/2/1 3/3/1 4/1/1\r\nf 1 2 3 4 5\r\nf -3//1 -2//1 -1//1\r\n")
    vertices, triangles = raylab.load_mesh(path)
    np.testing.assert_array_equal(vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [-0.5, 0.5, 0]])
    assert triangles.shape == (6, 3)
    assert set(triangles[:2].ravel()) == {0, 1, 2, 3}
    assert set(triangles[2:5].ravel()) == {0, 1, 2, 3, 4}
    np.testing.assert_array_equal(triangles[5], [2, 3, 4])


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
