"""raylab.write_image through Blender's writer (what the extension uses, having no OpenImageIO) writes the
same pictures as the OpenImageIO module: 8-bit sRGB PNG within one level, float EXR within half-float
rounding, the top row first, and the same errors."""
import numpy as np
import pytest

import bpy
from raylab import _raylab_images
from raylab.blender import image_files


def gradient(height=24, width=40):
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    image = np.stack([x / (width - 1), y / (height - 1), np.full_like(x, 0.18), np.ones_like(x)], axis=2)
    image[0, :, :3] = [1.0, 0.0, 0.0]  # a red top row: rows must not come out upside down
    return image


def read_back(path):
    picture = bpy.data.images.load(str(path))
    try:
        picture.colorspace_settings.name = image_files.linear_colorspace(picture)
        width, height = picture.size
        pixels = np.empty(width * height * 4, np.float32)
        picture.pixels.foreach_get(pixels)
        return pixels.reshape(height, width, 4)[::-1]  # top row first
    finally:
        bpy.data.images.remove(picture)


@pytest.mark.parametrize("extension, tolerance", [(".png", 1.5 / 255), (".exr", 2e-3)])
def test_blender_writer_matches_openimageio(tmp_path, extension, tolerance):
    image = gradient()
    ours, theirs = tmp_path / f"blender{extension}", tmp_path / f"oiio{extension}"
    image_files.write_image(ours, image)
    _raylab_images.write_image(str(theirs), image)
    a, b = read_back(ours), read_back(theirs)
    assert a.shape == b.shape == image.shape
    assert np.abs(a - b).max() <= tolerance
    assert a[0, 5, 0] > 0.9 and a[0, 5, 1] < 0.1  # the red row is on top


def test_blender_writer_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match=r"\(H, W, 4\)"):
        image_files.write_image(tmp_path / "x.png", np.zeros((4, 4)))
    with pytest.raises(RuntimeError, match="no_such_dir"):
        image_files.write_image(tmp_path / "no_such_dir" / "x.png", gradient())
    with pytest.raises(RuntimeError, match=r"\.png or \.exr"):
        image_files.write_image(tmp_path / "x.tif", gradient())
