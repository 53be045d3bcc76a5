"""The Python API of raylab: numpy in, numpy out; the native core does the work with the GIL released.

    V, T = raylab.load_mesh(path)                    # (V,3) float32, (T,3) uint32
    s = raylab.build(V, T, structure="bvh")          # one of raylab.STRUCTURES
    h = s.intersect(origins, directions)             # closest hits of N rays
    h = s.intersect(o, d, per_ray=True)              # h.per_ray["triangle_tests"]: each ray's work
    o = s.occluded(origins, directions)              # any hit (shadow rays)
    st = s.story(origin, direction)                  # everything one ray did
    b = s.boxes()                                    # the boxes, for drawing
    s2 = s.refit(moved_vertices)                     # the same triangles moved: boxes refitted, topology kept
    sc = raylab.Scene(structure="bvh")               # instances of shared meshes; sc.intersect(...)
    heat = raylab.heat_map(counts, maximum=100)      # false colour on a fixed scale (see heat.py)

Bad input raises ValueError naming the problem (for an argument: its name and what it accepts); a
build over the memory budget raises BuildError.
"""
import math
import sys

from .native import core as _raylab  # beside this file or from the raylab_core wheel
from .heat import HEAT_COLOURS, heat_legend, heat_map, heat_scale_text, heat_ticks  # noqa: F401 (numpy only)

__all__ = [
    "STRUCTURES", "STRUCTURE_INFO", "TRIANGLE_TESTS", "TRIANGLE_TEST_INFO", "CONTRACTS", "CONTRACT_INFO",
    "BUILDERS", "BUILDER_INFO", "SPLIT_METHODS", "SPLIT_METHOD_INFO",
    "COUNTERS", "COUNTER_INFO",
    "COST_PASSES", "COST_PASS_INFO", "COST_RAYS", "COST_RAYS_INFO",
    "DEFAULTS", "SAH_CONSTANTS", "TOP_LEVEL_REFIT_LIMIT", "RAY_STATUSES", "BuildError", "load_mesh", "build",
    "build_file",
    "Structure", "Scene", "Hits", "Statuses", "Occlusion", "RayStory", "SceneStory", "InstancePart", "render",
    "camera_rays", "image_size", "write_image",
    "HEAT_COLOURS", "heat_map", "heat_legend", "heat_ticks", "heat_scale_text",
]

# The core's vocabularies (native/python/vocabulary.cpp), never listed again in Python.
STRUCTURE_INFO = {s["name"]: s for s in _raylab.STRUCTURES}  # name -> label, description, parameters it uses...
STRUCTURES = tuple(STRUCTURE_INFO)                             # ("none", "aabb", "octree", "bvh", ...)
TRIANGLE_TEST_INFO = {t["name"]: t for t in _raylab.TRIANGLE_TESTS}
TRIANGLE_TESTS = tuple(TRIANGLE_TEST_INFO)                     # ("watertight", "moller_trumbore")
CONTRACT_INFO = {c["name"]: c for c in _raylab.CONTRACTS}      # README "The price of exactness"
CONTRACTS = tuple(CONTRACT_INFO)                               # ("exact", "fast")
BUILDER_INFO = {b["name"]: b for b in _raylab.BUILDERS}        # the BVH's builders (README "Builders")
BUILDERS = tuple(BUILDER_INFO)                                 # ("sah", "median", "spatial_median", "lbvh")
SPLIT_METHOD_INFO = {m["name"]: m for m in _raylab.SPLIT_METHODS}  # split_costs()["method"]: how a node was split
SPLIT_METHODS = tuple(SPLIT_METHOD_INFO)
COUNTER_INFO = {c["name"]: c for c in _raylab.COUNTERS}      # the keys of every stats dict, in order
COUNTERS = tuple(COUNTER_INFO)
# The cost passes (native/include/raylab/cost_passes.h): render-pass name -> counter, label, description;
# render(...).cost holds every counter per pixel, these are the ones offered as passes.
COST_PASS_INFO = {p["name"]: p for p in _raylab.COST_PASSES}
COST_PASSES = tuple(COST_PASS_INFO)                            # ("raylab Rays", "raylab Box Tests", ...)
COST_RAYS_INFO = {r["name"]: r for r in _raylab.COST_RAYS}     # render settings' cost_rays: "all", "primary"
COST_RAYS = tuple(COST_RAYS_INFO)
DEFAULTS = dict(_raylab.BUILD_DEFAULTS)                        # structure, max_depth, leaf_size, ...
SAH_CONSTANTS = dict(_raylab.SAH_CONSTANTS)                    # node_visit, leaf_block: Structure.sah_cost's
TOP_LEVEL_REFIT_LIMIT = _raylab.TOP_LEVEL_REFIT_LIMIT          # a refitted top level costing more is rebuilt
RAY_STATUSES = _raylab.RAY_STATUSES                            # a story's status, in rising priority
BuildError = _raylab.BuildError

_D = DEFAULTS


class _Record:
    """Named fields filled from the native module's dict."""

    __slots__ = ()

    def __init__(self, fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(self.__slots__)})"


class Hits(_Record):
    """Closest hits of N rays: t (inf on miss), triangle, u, v, instance (-1 on miss), hit, stats,
    per_ray (see Structure.intersect)."""

    __slots__ = ("t", "triangle", "u", "v", "instance", "hit", "stats", "per_ray")

    def __len__(self):
        return len(self.t)


class Statuses(_Record):
    """Closest hits of N rays with each ray's status: status (N,) int8, an index into RAY_STATUSES;
    t, triangle, u, v, instance, hit as in Hits."""

    __slots__ = ("status", "t", "triangle", "u", "v", "instance", "hit")

    def __len__(self):
        return len(self.t)


class Occlusion(_Record):
    """Any-hit results of N rays: hit (N,) bool, stats, per_ray (see Structure.intersect)."""

    __slots__ = ("hit", "stats", "per_ray")

    def __len__(self):
        return len(self.hit)


class RayStory(_Record):
    """What one ray did, in order: status, boxes tested, nodes visited, triangles tested, hit, stats.

    status is "missed_root", "missed_nodes", "missed_triangles" or "hit_object".
    """

    __slots__ = ("status", "boxes", "nodes", "node_depths", "triangles", "triangle_hits", "hit", "stats")


class SceneStory(_Record):
    """What one world ray did in a Scene, recorded by the same traversal as Scene.intersect.

    status and stats are the scene's (stats equal intersect(count=True)'s for this ray); hit is None
    or dict(t, triangle, u, v, instance, point) in world space. top_boxes and top_nodes: the top
    level's boxes (world space, as in RayStory.boxes) and nodes, empty for structures without a top
    level. instances: one InstancePart per instance queried, in order.
    """

    __slots__ = ("status", "top_boxes", "top_nodes", "instances", "hit", "stats")

    def __init__(self, fields):
        super().__init__(fields)
        self.instances = [InstancePart(p) for p in self.instances]


class InstancePart(_Record):
    """One instance's part of a SceneStory: instance and mesh ids, matrix ((4,4) object to world),
    and story, the RayStory of the ray carried into object space (boxes and hit in object space; its
    t is the world ray's t)."""

    __slots__ = ("instance", "mesh", "matrix", "story")

    def __init__(self, fields):
        super().__init__(fields)
        self.story = RayStory(self.story)


def load_mesh(path):
    """Reads an OBJ file: ((V,3) float32 vertices, (T,3) uint32 triangles).

    OSError if the file cannot be read; ValueError for a path with a NUL character, anything but a regular
    file (a directory, a FIFO, a device), a file over 1 GiB, or a file whose `v` lines lack three finite
    numbers or whose faces name no vertex of the file (the message names the file and line).
    """
    return _raylab.load_mesh(path)  # path: str, bytes or os.PathLike, checked natively


class Structure:
    """An acceleration structure over one mesh, built by build() or build_file()."""

    __slots__ = ("native",)

    def __init__(self, native):
        self.native = native  # the _raylab.Structure; other native parts (the renderer) take it

    structure = property(lambda self: self.native.structure, doc=f"one of STRUCTURES: {', '.join(STRUCTURES)}")
    build_seconds = property(lambda self: self.native.build_seconds)
    memory_bytes = property(lambda self: self.native.memory_bytes, doc="the structure's own bytes, without the mesh")
    triangle_count = property(lambda self: self.native.triangle_count)
    vertex_count = property(lambda self: self.native.vertex_count)
    max_depth = property(lambda self: self.native.max_depth)
    leaf_size = property(lambda self: self.native.leaf_size)
    triangle_test = property(lambda self: self.native.triangle_test)
    contract = property(lambda self: self.native.contract)
    builder = property(lambda self: self.native.builder, doc=f"one of BUILDERS: {', '.join(BUILDERS)}")
    refitted = property(lambda self: self.native.refitted,
                        doc="made by refit() keeping its source's topology (False for a build, and for a refit "
                            "of a kind whose refit rebuilds: STRUCTURE_INFO[name]['refits'] is False)")

    def refit(self, vertices):
        """A new Structure over the same triangles at new (V,3) vertex positions (a deforming mesh,
        an animation frame): the boxes are recomputed bottom-up and the topology is kept, which is
        much faster than build() but lets the tree's quality (sah_cost()) degrade as the mesh moves
        away from the pose it was built for. The hits stay exact. Kinds whose topology depends on the
        positions (STRUCTURE_INFO[name]["refits"] False: octree, grid) are rebuilt instead, with this
        structure's settings; the result's `refitted` says which happened and build_seconds is the
        refit's time. This structure is left unchanged (other threads may be tracing it).

        vertices must have this mesh's vertex count (vertex_count) and finite coordinates within the
        build's limit; otherwise ValueError naming `vertices`.
        """
        return Structure(self.native.refit(vertices))

    def sah_cost(self):
        """The BVH's surface area heuristic cost, what its builder minimises, normalised by the root
        box's area: SAH_CONSTANTS["node_visit"] (a node visit, in units of testing one leaf block of
        SAH_CONSTANTS["leaf_block"] triangles) for the root and each inner child box, plus
        ceil(triangles / leaf_block) for each leaf, each weighted by its box's area over the root's
        (the chance that a ray through the root enters it). Lower is a better tree; a refit's rises as
        the mesh deforms. None for kinds other than bvh."""
        return self.native.sah_cost()

    def tree(self):
        """The tree as numpy arrays, node i being boxes()[i] (the ids of boxes() and of the stories).

        A dict: width W; children (M,W) i32, row i the children of inner node i (-1 for an empty slot;
        the M inner nodes come first, for the BVH ids >= M are its leaves); parent (N,) i32 (-1 for the
        root); depth (N,) i32; lo, hi (N,3) f32; leaf (N,) bool; triangle_count (N,) u32 (a subtree's
        distinct triangles, as boxes()); sah_cost (N,) f64, each node's share of sah_cost() (its box's
        area over the root's times SAH_CONSTANTS["node_visit"], or a leaf's ceil(triangles /
        leaf_block) so weighted), so that sah_cost.sum() == sah_cost(); node_count N.

        The BVH's tree is the wide tree its traversal walks (W = 4 or 8, what the CPU runs): its builder
        makes a binary tree and collapses it, each wide node being the binary node at its top with its
        largest inner descendants opened until it has W children. The octree gives its nodes (W = 8, a
        row by octant, a row for every node; sah_cost None). Other kinds raise ValueError: none and aabb
        have no tree, and the grid's occupied cells are one level, boxes()."""
        return self.native.tree()

    def split_costs(self, node):
        """Why BVH node `node` (a tree() id) is split where it is, or is a leaf: the builder's own
        decision, recomputed by the builder's code over the node's triangles. A wide node's decision is
        that of the binary node at its top: the chosen split puts a prefix of its children on the left.

        A dict. The SAH's candidates, as the binned SAH builder sees them (its bins, its constants:
        SAH_CONSTANTS): candidates is "binned" (15 planes per axis between 16 bins over the centroids'
        box) or "sorted" (nodes of 16 triangles or fewer: every split between the triangles sorted by
        centroid); positions (3,K) f32, each plane's coordinate along x, y and z; costs (3,K) f32, the
        SAH cost of splitting there, node_visit + (A_L B_L + A_R B_R) / A (A: half the surface area of
        a side's or the node's box, B: ceil(triangles / leaf_block)), inf where a side is empty;
        left_counts (3,K) u32; leaf_cost, B of the node. The choice: method (one of SPLIT_METHODS; the
        SAH's, or the median, spatial_median and lbvh builders' own), axis (-1 without a plane),
        position (NaN without one), candidate (the SAH's: its index in positions[axis], else -1), cost
        (the SAH cost of the split made, or of the leaf), left_triangles (the sorted triangle ids put
        left). Also node, count, lo and hi (3,). ValueError for kinds other than bvh, or a bad id.

        A refitted BVH (refit()) keeps the tree built for the old positions: its split_costs are what
        the builder would decide over the moved triangles, which the tree may no longer follow."""
        return self.native.split_costs(node)

    def mesh(self):
        """A copy of the mesh: ((V,3) float32, (T,3) uint32)."""
        return self.native.mesh

    def intersect(self, origins, directions, tmin=0.0, tmax=math.inf, count=False, threads=None, per_ray=False):
        """Closest hits in (tmin, tmax] of rays given as (N,3) origins and directions (either may be
        one (3,) row shared by all rays). Returns Hits. With count=True, h.stats is a dict with
        the COUNTERS as keys (rays, rays_ignored, box_tests, ...); otherwise None. With per_ray=True,
        h.per_ray is a dict with the COUNTERS as keys, each an (N,) uint32 array of every ray's own
        work (h.stats, then filled too, is their sum); otherwise None. threads: how many threads trace
        (None or 0 = all cores; 1 for single-thread timings, n - 1 to leave a core free; more than
        the cores run on the cores); the answers and counts are the same on any number."""
        return Hits(self.native.intersect(origins, directions, tmin, tmax, count, per_ray, threads))

    def occluded(self, origins, directions, tmin=0.0, tmax=math.inf, count=False, threads=None, per_ray=False):
        """Whether anything is hit in (tmin, tmax]: the shadow-ray query. Returns Occlusion.
        count, per_ray and threads as in intersect()."""
        return Occlusion(self.native.occluded(origins, directions, tmin, tmax, count, per_ray, threads))

    def boxes(self, lines=False, depth_min=0, depth_max=None, leaves_only=False, palette=None, fade=False,
              alpha_scale=1.0):
        """The boxes: dict lo (B,3) f32, hi (B,3) f32, depth (B,) i32, leaf (B,) bool, triangle_count (B,) u32.

        lines=True: instead, the boxes with depth_min <= depth <= depth_max (None: no upper end), only
        the leaves with leaves_only, as line geometry ready for a GPU batch: dict positions (8B,3) f32
        (corner c of a box takes hi on axis a where bit a of c is set), colors (8B,4) f32, indices
        (12B,2) u32 (the 12 edges), box_count. A box at depth d is coloured palette[d % P] ((P,4) RGBA
        rows, or one (4,) colour; None: white); fade=True multiplies its alpha by
        max(1 / (1 + 0.35 d) * min(1, sqrt(200 / B)), 0.12), and every alpha is multiplied by
        alpha_scale."""
        return self.native.boxes(lines, depth_min, depth_max, leaves_only, palette, fade, alpha_scale)

    def statuses(self, origins, directions, tmin=0.0, tmax=math.inf, threads=None):
        """Closest hits of N rays plus each ray's status, what its story would say without recording
        it. Returns Statuses. threads as in intersect()."""
        return Statuses(self.native.statuses(origins, directions, tmin, tmax, threads))

    def story(self, origin, direction, tmin=0.0, tmax=math.inf):
        """The whole closest-hit story of one ray given as (3,) origin and direction."""
        return RayStory(self.native.story(origin, direction, tmin, tmax))

    def __repr__(self):
        return (f"<raylab.Structure {self.structure}: {self.triangle_count} triangles, "
                f"{self.memory_bytes} bytes, built in {self.build_seconds:.3f} s>")


def build(vertices, triangles, structure=_D["structure"], max_depth=_D["max_depth"], leaf_size=_D["leaf_size"],
          triangle_test=_D["triangle_test"], contract=_D["contract"], builder=_D["builder"], memory_budget=None):
    """Builds a structure over (V,3) float32 vertices and (T,3) uint32 triangles.

    Other real dtypes are converted (vertices to float32); negative or out-of-range indices, NaN or
    infinite coordinates, wrong shapes and impossible settings raise ValueError. max_depth is the
    octree's depth (0 = root only); leaf_size the triangles per octree or BVH leaf; contract "exact"
    (brute force's hit, bit for bit) or "fast" (Embree's tests, where STRUCTURE_INFO[structure]
    ["uses_contract"]; CONTRACT_INFO says what each promises); builder how the BVH chooses its splits
    (one of BUILDERS, where STRUCTURE_INFO[structure]["uses_builder"]; BUILDER_INFO describes each);
    memory_budget the bytes a build may use (None = 4 GiB), beyond which it raises BuildError.
    """
    return Structure(_raylab.build(vertices, triangles, structure, max_depth, leaf_size, triangle_test, contract,
                                   builder, memory_budget))


def build_file(path, structure=_D["structure"], max_depth=_D["max_depth"], leaf_size=_D["leaf_size"],
               triangle_test=_D["triangle_test"], contract=_D["contract"], builder=_D["builder"],
               memory_budget=None):
    """build() over the mesh read from an OBJ file."""
    return Structure(_raylab.build_file(path, structure, max_depth, leaf_size, triangle_test, contract, builder,
                                        memory_budget))


class Scene:
    """Meshes and instances of them (mesh + (4,4) row-major object-to-world matrix + material).

    One structure per mesh, in object space, shared by all its instances; commit() builds what is
    missing or stale (a moved instance costs no rebuild; refit_mesh refits a deformed mesh's structure;
    moved instances refit the top level). Queries return world-space t and the
    instance id of each hit. Any threads may change, commit and query it at once: a query sees the
    last commit() whole, except on a thread with changes of its own not committed yet (it raises).
    """

    __slots__ = ("native",)

    def __init__(self, structure=_D["structure"], max_depth=_D["max_depth"], leaf_size=_D["leaf_size"],
                 triangle_test=_D["triangle_test"], contract=_D["contract"], builder=_D["builder"],
                 memory_budget=None):
        self.native = _raylab.Scene(structure, max_depth, leaf_size, triangle_test, contract, builder, memory_budget)

    def add_mesh(self, vertices, triangles, normals=None):
        """Adds a mesh ((V,3) vertices, (T,3) triangles, validated as in build()); returns its id.

        normals, for smooth shading in render(): (T,3,3) object-space normals of each triangle's
        corners, or (V,3) per-vertex normals; None shades flat. Only the renderer reads them; a wrong
        shape or a NaN / infinite entry raises ValueError.
        """
        return self.native.add_mesh(vertices, triangles, normals)

    def replace_mesh(self, mesh, vertices, triangles, normals=None):
        """Replaces mesh `mesh` (and its normals, as add_mesh): only its own structure is rebuilt at
        the next commit()."""
        self.native.replace_mesh(mesh, vertices, triangles, normals)

    def refit_mesh(self, mesh, vertices, normals=None):
        """New (V,3) positions for mesh `mesh`'s vertices, its triangles kept (a deforming mesh): at
        the next commit() its structure is refitted from the committed one (see Structure.refit; octree
        and grid rebuild) instead of built anew. normals as in add_mesh (None: flat). ValueError,
        changing nothing, unless vertices has the mesh's vertex count and finite coordinates."""
        self.native.refit_mesh(mesh, vertices, normals)

    def add_instance(self, mesh, matrix, material=0):
        """Adds an instance of mesh `mesh` with a (4,4) row-major object-to-world matrix; returns its id."""
        return self.native.add_instance(mesh, matrix, material)

    def set_transform(self, instance, matrix):
        self.native.set_transform(instance, matrix)

    def set_settings(self, structure=_D["structure"], max_depth=_D["max_depth"], leaf_size=_D["leaf_size"],
                     triangle_test=_D["triangle_test"], contract=_D["contract"], builder=_D["builder"],
                     memory_budget=None):
        """New build settings: every mesh structure is rebuilt at the next commit()."""
        self.native.set_settings(structure, max_depth, leaf_size, triangle_test, contract, builder, memory_budget)

    def commit(self):
        """Builds what changed since the last commit; queries need it."""
        self.native.commit()

    def intersect(self, origins, directions, tmin=0.0, tmax=math.inf, count=False, threads=None, per_ray=False):
        """Closest hits of world-space rays, as Structure.intersect (count, per_ray and threads too);
        h.instance says which instance. A ray's counts are the scene's: the top level's work plus
        every queried instance's."""
        return Hits(self.native.intersect(origins, directions, tmin, tmax, count, per_ray, threads))

    def occluded(self, origins, directions, tmin=0.0, tmax=math.inf, count=False, threads=None, per_ray=False):
        """Whether anything is hit, as Structure.occluded (count, per_ray and threads too)."""
        return Occlusion(self.native.occluded(origins, directions, tmin, tmax, count, per_ray, threads))

    def statuses(self, origins, directions, tmin=0.0, tmax=math.inf, threads=None):
        """Closest hits of world rays with each ray's status, as Structure.statuses (h.instance set)."""
        return Statuses(self.native.statuses(origins, directions, tmin, tmax, threads))

    def story(self, origin, direction, tmin=0.0, tmax=math.inf):
        """Everything one world ray did: a SceneStory."""
        return SceneStory(self.native.story(origin, direction, tmin, tmax))

    def structure(self, mesh):
        """The committed Structure of mesh `mesh` (object space), e.g. for its boxes()."""
        return Structure(self.native.structure(mesh))

    def matrix(self, instance):
        """The (4,4) object-to-world matrix of instance `instance`, as the scene holds it (float32)."""
        return self.native.matrix(instance)

    def clear_instances(self):
        """Drops every instance; the meshes and their built structures stay for new instances."""
        self.native.clear_instances()

    mesh_count = property(lambda self: self.native.mesh_count)
    instance_count = property(lambda self: self.native.instance_count)
    memory_bytes = property(lambda self: self.native.memory_bytes, doc="structures and top level, in bytes")
    build_seconds = property(lambda self: self.native.build_seconds, doc="of the last commit()")
    top_level_update = property(
        lambda self: self.native.top_level_update,
        doc="what the last commit() did to the top level over the instances: 'kept' (no instance box moved), "
            "'refitted' (the same instances moved: boxes recomputed, topology kept, while its SAH cost stays "
            "within TOP_LEVEL_REFIT_LIMIT times its cost when built) or 'built'")
    top_level_sah_cost = property(lambda self: self.native.top_level_sah_cost,
                                  doc="the top level's SAH cost (as Structure.sah_cost, one instance per leaf)")

    def bounds(self):
        """World bounds of every instance: ((3,) lo, (3,) hi)."""
        return self.native.bounds()


# The renderer (native/python/render_bindings.cpp) takes a Scene above or its native scene. Its result
# has image, instance, distance, stats, cancelled, and cost: every COUNTERS name -> (H, W) float32, each
# pixel's traversal work over the rays settings["cost_rays"] names (COST_RAYS: "all", the default, or
# "primary"), every super-sample's; with "all" they sum to stats' counters.
render = _raylab.render


def camera_rays(camera, points):
    """The renderer's own camera rays through (N,2) raster points of a camera dict (as render() takes
    it; x to the right, y down from the top edge, pixel (i, j) centred at (i + 0.5, j + 0.5)): world
    ((N,3) origins, (N,3) unit directions), float32."""
    rays = _raylab.camera_rays(camera, points)
    return rays["origins"], rays["directions"]


def image_size(camera):
    """(width, height) in pixels of the image render() makes with a camera dict (resolution times
    percentage, in whole pixels as the renderer's camera counts them)."""
    rays = _raylab.camera_rays(camera, [[0.5, 0.5]])
    return int(rays["width"]), int(rays["height"])


def write_image(path, image):
    """Writes an (H, W, 4) or (H, W, 3) linear image, row 0 the top row: .png 8-bit with the sRGB curve,
    .exr float. Through OpenImageIO (the _raylab_images module of a build made by ./raylab setup); in
    the Blender extension, which leaves OpenImageIO out, through Blender's own image writer. An image
    with a NaN or infinite channel is refused (ValueError: how many pixels, where the first is)."""
    try:
        from . import _raylab_images
    except ImportError:
        if "bpy" not in sys.modules:
            raise ImportError("raylab.write_image needs the _raylab_images module (OpenImageIO), which this "
                              "build of raylab does not carry: build raylab with ./raylab setup") from None
        from .blender import image_files
        return image_files.write_image(path, image)
    return _raylab_images.write_image(path, image)
