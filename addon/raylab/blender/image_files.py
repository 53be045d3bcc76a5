"""raylab.write_image through Blender's image writer, for the extension, which ships no OpenImageIO.

Same contract as the OpenImageIO writer: (H, W, 3|4) linear values, row 0 the top row; .png 8-bit with
the sRGB curve, .exr float; a bad array is a ValueError, a path that cannot be written a RuntimeError."""
import os

import bpy
import numpy as np

FORMATS = {".png": 'PNG', ".exr": 'OPEN_EXR'}


def write_image(path, image):
    path = os.fspath(path)
    file_format = FORMATS.get(os.path.splitext(path)[1].lower())
    if file_format is None:
        raise RuntimeError(f"cannot write '{path}': the file name must end in .png or .exr")
    try:
        pixels = np.asarray(image, np.float32)
    except (TypeError, ValueError):
        raise ValueError("image must be an array of numbers") from None
    if pixels.ndim != 3 or pixels.shape[2] not in (3, 4) or pixels.shape[0] == 0 or pixels.shape[1] == 0:
        raise ValueError("image must be (H, W, 4) or (H, W, 3) with H, W > 0")
    height, width = pixels.shape[:2]
    bad = ~np.isfinite(pixels).all(axis=2)
    if bad.any():  # as image_io.cpp words it: a NaN is no colour
        row, column = np.argwhere(bad)[0]
        raise ValueError(f"cannot write image '{path}': {int(bad.sum())} of its {height * width} pixels are not finite "
                         f"(NaN or infinite), the first at row {row}, column {column} (row 0 the top row)")
    rgba = np.ones((height, width, 4), np.float32)  # a missing alpha is opaque
    rgba[:, :, :pixels.shape[2]] = pixels
    if not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise RuntimeError(f"cannot write '{path}': its folder does not exist")
    picture = bpy.data.images.new("raylab write_image", width, height, alpha=True, float_buffer=True)
    try:
        picture.filepath_raw = path
        picture.file_format = file_format
        # PNG: Blender converts the linear floats to 8-bit sRGB itself. EXR: the floats as they are
        # (without this, Blender writes them sRGB-encoded). Set before the pixels: 5.x regenerates a
        # generated image (black) when its colour settings change.
        picture.colorspace_settings.is_data = file_format == 'OPEN_EXR'
        picture.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())  # Blender's rows go up
        picture.save()
    finally:
        bpy.data.images.remove(picture)


def linear_colorspace(picture):
    """The name of the linear Rec.709 colour space: 'Linear' in 3.x, 'Linear Rec.709' from 4.0."""
    names = {item.identifier for item in picture.colorspace_settings.bl_rna.properties["name"].enum_items}
    return next(name for name in ("Linear Rec.709", "Linear") if name in names)
