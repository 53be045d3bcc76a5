"""Drawing over the 3D viewport: GPU batches of coloured lines and points, box wireframes, flat shapes and
text in the region's pixels (POST_PIXEL: the tree view, the charts), and the request to redraw every 3D
viewport. The gpu module is imported when drawing only (it is unavailable in
background mode), so everything here can be imported headless."""
import bpy
import numpy as np
from mathutils import Matrix

# The 12 edges of a box over its 8 corners, corner c = (x bit 0, y bit 1, z bit 2) of lo/hi.
BOX_EDGES = np.array([(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
                      (0, 4), (1, 5), (2, 6), (3, 7)], dtype=np.uint32)
_CORNER_BITS = np.array([[(c >> axis) & 1 for axis in range(3)] for c in range(8)], dtype=bool)

THIN = 'SMOOTH_COLOR'            # 1-pixel lines and points: cheap even for 100k boxes
THICK = 'POLYLINE_SMOOTH_COLOR'  # wide lines (a geometry shader): for the few lines that stand out
# Points of a given size: 4.0+ has point shaders whose size is a uniform (on Vulkan and Metal the only
# size a point gets); 3.x draws them with THIN and the GL point size.
POINTS = 'POINT_FLAT_COLOR'
_point_shader = []


def point_shader_name():
    """POINTS where this Blender has it, else THIN (asked once, when first drawing)."""
    if not _point_shader:
        import gpu
        try:
            gpu.shader.from_builtin(POINTS)
            _point_shader.append(POINTS)
        except ValueError:
            _point_shader.append(THIN)
    return _point_shader[0]


def tag_redraw(context=None):
    """Asks every 3D viewport of every window to redraw."""
    wm = (context or bpy.context).window_manager
    for window in getattr(wm, "windows", []):
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


def box_wireframe(lo, hi):
    """Corners (8B,3) float32 and edge indices (12B,2) uint32 of B boxes."""
    corners = np.where(_CORNER_BITS[None, :, :], hi[:, None, :], lo[:, None, :]).reshape(-1, 3)
    indices = (BOX_EDGES[None, :, :] + (8 * np.arange(len(lo), dtype=np.uint32))[:, None, None]).reshape(-1, 2)
    return np.ascontiguousarray(corners, dtype=np.float32), np.ascontiguousarray(indices, dtype=np.uint32)


def make_batch(primitive, positions, colors, indices=None, shader_name=THIN):
    import gpu
    from gpu_extras.batch import batch_for_shader
    return batch_for_shader(gpu.shader.from_builtin(shader_name), primitive, {"pos": positions, "color": colors},
                            indices=indices)


def draw_batch(batch, model_matrix, xray, shader_name=THIN, width=1.0, point_size=1.0):
    """Draws a batch made by make_batch with `model_matrix` (4,4) carrying it to the world."""
    import gpu
    shader = gpu.shader.from_builtin(shader_name)
    gpu.state.blend_set('ALPHA')
    gpu.state.depth_test_set('NONE' if xray else 'LESS_EQUAL')
    gpu.state.depth_mask_set(False)
    gpu.state.point_size_set(point_size)
    if shader_name == THICK:
        shader.bind()
        shader.uniform_float("viewportSize", gpu.state.viewport_get()[2:])
        shader.uniform_float("lineWidth", width)
    elif shader_name == POINTS:
        shader.bind()
        shader.uniform_float("size", point_size)
    with gpu.matrix.push_pop():
        gpu.matrix.multiply_matrix(Matrix(np.asarray(model_matrix).tolist()))
        batch.draw(shader)
    gpu.state.depth_test_set('NONE')
    gpu.state.blend_set('NONE')


def draw_segments(starts, ends, colors, xray, width):
    """World-space segments (N,3)-(N,3), one RGBA colour each; wide ones with the polyline shader."""
    positions = np.ascontiguousarray(np.stack([starts, ends], axis=1).reshape(-1, 3), dtype=np.float32)
    shader = THICK if width > 1.0 else THIN
    batch = make_batch('LINES', positions, np.repeat(colors, 2, axis=0), shader_name=shader)
    draw_batch(batch, np.identity(4), xray, shader, width)


def draw_points(points, color, xray, size):
    """World-space points (N,3) in one RGBA colour, or (N,4) colours one each, `size` pixels across."""
    if len(points) == 0:
        return
    positions = np.ascontiguousarray(points, dtype=np.float32)
    color = np.asarray(color, dtype=np.float32)
    colors = np.ascontiguousarray(color if color.ndim == 2 else np.tile(color, (len(points), 1)))
    shader = point_shader_name()
    draw_batch(make_batch('POINTS', positions, colors, shader_name=shader), np.identity(4), xray, shader,
               point_size=size)


# --- in the region's pixels (a POST_PIXEL handler) ---------------------------------------------------

FRAME = (0.05, 0.05, 0.06, 1.0)  # a frame's fill: opaque, so the boxes behind never show through the text
WHITE = (1.0, 1.0, 1.0, 1.0)
TEXT_PIXELS = 12                 # the charts' font size
TEXT_WIDTH = 7.0                 # pixels a character of it takes, at most (the tests' estimate too)


def _pixel_positions(points):
    points = np.asarray(points, dtype=np.float32).reshape(-1, 2)
    return np.ascontiguousarray(np.concatenate([points, np.zeros((len(points), 1), np.float32)], 1))


def _pixel_colours(colour, count):
    colour = np.asarray(colour, dtype=np.float32)
    return np.ascontiguousarray(colour if colour.ndim == 2 else np.tile(colour, (count, 1)))


def pixel_batch(primitive, points, colour, width=1.0):
    """Region pixels (N,2) as `primitive` in one RGBA colour, or (N,4) colours one each."""
    import gpu
    positions = _pixel_positions(points)
    if len(positions) == 0:
        return
    batch = make_batch(primitive, positions, _pixel_colours(colour, len(positions)))
    gpu.state.blend_set('ALPHA')
    gpu.state.line_width_set(width)
    batch.draw(gpu.shader.from_builtin(THIN))
    gpu.state.line_width_set(1.0)
    gpu.state.blend_set('NONE')


def pixel_triangles(points, colour):
    pixel_batch('TRIS', points, colour)


def pixel_lines(points, colour, width=1.0):
    pixel_batch('LINES', points, colour, width)


def pixel_frame(frame, colour=FRAME):
    """A filled rectangle (x, y, width, height)."""
    x, y, w, h = frame
    pixel_triangles(np.array([[x, y], [x + w, y], [x + w, y + h], [x, y], [x + w, y + h], [x, y + h]],
                             np.float32), colour)


def pixel_squares(xs, ys, size, colours):
    """Filled squares `size` pixels across centred on (xs, ys), one RGBA colour each ((N,4))."""
    half = size / 2.0
    corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)], np.float32) * half
    points = (np.stack([xs, ys], 1)[:, None, :] + corners[None, :, :]).reshape(-1, 2)
    pixel_triangles(points, np.repeat(colours, 6, axis=0))


def pixel_outline(x, y, size, colour):
    """A square's outline, `size` pixels across, 2 pixels wide, centred on (x, y)."""
    h = size / 2.0
    square = np.array([[x - h, y - h], [x + h, y - h], [x + h, y - h], [x + h, y + h], [x + h, y + h],
                       [x - h, y + h], [x - h, y + h], [x - h, y - h]], np.float32)
    pixel_batch('LINES', square, colour, width=2.0)


def pixel_text(x, y, text, colour=WHITE):
    import blf
    font = 0
    blf.size(font, TEXT_PIXELS)
    blf.color(font, *colour)
    blf.position(font, x, y, 0)
    blf.draw(font, text)
