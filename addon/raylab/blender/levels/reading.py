"""The level format: a level is data in levels/<id>/ (level.toml, text.md, diagrams/*.png). Reads and
checks level.toml (settings, controls, tasks and their declarative conditions) and text.md (a small
Markdown: headings, paragraphs, bullets, diagrams). No bpy: this runs, and can be tested, in plain Python.

Conditions are small declarative tables, never code:

    { property = "raylab.max_depth", at_least = 5 }          also equals, at_most, in = [...]
    { id_property = "raylab_last_render", exists = true }    also length_at_least, changed = true
    { object = "mesh", moved_at_least = 1.0 }                also tilted_at_least (degrees), mesh_changed,
                                                             deforms (a modifier, shape keys or an armature
                                                             parent may move its vertices frame by frame)
    { all = [ ... ] }, { any = [ ... ] }

An id_property may name a value inside a record with dots: "raylab_heat_maps.structures.bvh.hardest" is
scene["raylab_heat_maps"]["structures"]["bvh"]["hardest"] (missing: it does not exist). Two more tests
read such values:

    { id_property = "raylab_heat_maps.structures.bvh.hardest", decreased = true }
        the number is lower than when the task began (a record that did not exist then cannot decrease)
    { probe_pixel_near = "raylab_heat_maps.structures.octree.probe_pixel", within = 3 }
        the probe's source is the camera and its pixel (probe_pixel_x, probe_pixel_y) is at most
        `within` pixels from the [x, y] stored there, in x and in y

A level may add objects beside its mesh, each a shipped mesh scaled to `size` metres (its largest side)
at `location` (both times scene_scale), in its own colour:

    [[objects]]
    name = "Rod"
    file = "rod.obj"
    size = 1.6
    location = [0.0, -1.2, 0.2]
    color = [0.3, 0.6, 0.9]
"""
import os
import re
import tomllib

# raylab/blender/levels/reading.py: the package is three folders up.
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The installable zip carries the levels inside the package; a checkout has them at the top.
LEVEL_ROOTS = (os.path.join(PACKAGE_DIR, "levels"),
               os.path.join(os.path.dirname(os.path.dirname(PACKAGE_DIR)), "levels"))
SETTING_GROUPS = ("raylab", "raylab_render", "raylab_tree")
COMPARISONS = ("equals", "in", "at_least", "at_most")
ID_PROPERTY_TESTS = ("exists", "length_at_least", "changed", "decreased")
PROBE_TESTS = ("within",)
OBJECT_KEYS = {"name": str, "file": str, "size": (int, float), "location": list, "color": list}
OBJECT_TESTS = ("moved_at_least", "tilted_at_least", "mesh_changed", "deforms")


class LevelError(ValueError):
    """A level folder that cannot be used: says which file and what is wrong."""


# --- reading levels --------------------------------------------------------------------------------

class Task:
    __slots__ = ("text", "condition")

    def __init__(self, text, condition):
        self.text = text
        self.condition = condition


class Level:
    __slots__ = ("id", "order", "title", "goal", "folder", "mesh", "objects", "scene_scale", "scene", "camera",
                 "settings", "probe", "tasks", "controls", "blocks")

    def __init__(self, folder, data):
        where = os.path.join(folder, "level.toml")
        self.folder = folder
        self.id = _required(data, "id", str, where)
        self.order = _required(data, "order", int, where)
        self.title = _required(data, "title", str, where)
        self.goal = _required(data, "goal", str, where)
        self.mesh = _table(data, "mesh", where)
        _required(self.mesh, "file", str, where + " [mesh]")
        self.objects = _objects(data.get("objects", []), where)
        self.scene_scale = float(data.get("scene_scale", 1.0))
        if not self.scene_scale > 0.0:
            raise LevelError(f"{where}: scene_scale must be positive")
        self.scene = _table(data, "scene", where, optional=True)
        self.camera = _table(data, "camera", where, optional=True)
        self.settings = {group: _table(data, group, where, optional=True) for group in SETTING_GROUPS}
        self.probe = data.get("probe")
        tasks = data.get("tasks", [])
        if not isinstance(tasks, list):
            raise LevelError(f"{where}: 'tasks' must be a list of [[tasks]] tables")
        self.tasks = []
        for i, task in enumerate(tasks):
            here = f"{where} task {i + 1}"
            if not isinstance(task, dict):
                raise LevelError(f"{here}: must be a table with 'text' and 'condition'")
            condition = _table(task, "condition", here)
            validate_condition(condition, here)
            self.tasks.append(Task(_required(task, "text", str, here), condition))
        self.controls = data.get("controls", [])
        for control in self.controls:
            group, _, name = str(control).partition(".")
            if not (group in SETTING_GROUPS or group.startswith("operator:")) or not name:
                raise LevelError(f"{where}: a control is '<group>.<setting>' (group: {', '.join(SETTING_GROUPS)}) "
                                 f"or 'operator:<module>.<operator>', not {control!r}")
        unknown = set(data) - {"id", "order", "title", "goal", "mesh", "objects", "scene_scale", "scene", "camera",
                               "probe", "tasks", "controls", *SETTING_GROUPS}
        if unknown:
            raise LevelError(f"{where}: unknown keys {sorted(unknown)}")
        self.blocks = read_text(os.path.join(folder, "text.md"))


def _required(table, key, kind, where):
    if key not in table:
        raise LevelError(f"{where}: '{key}' is missing")
    if not isinstance(table[key], kind):
        raise LevelError(f"{where}: '{key}' must be a {kind.__name__}, not {table[key]!r}")
    return table[key]


def _objects(objects, where):
    """The [[objects]] tables, checked: name and file required, size positive, location and colour three
    numbers, names unique."""
    if not isinstance(objects, list):
        raise LevelError(f"{where}: 'objects' must be a list of [[objects]] tables")
    names = set()
    for i, obj in enumerate(objects):
        here = f"{where} object {i + 1}"
        if not isinstance(obj, dict):
            raise LevelError(f"{here}: must be a table with 'name' and 'file'")
        unknown = set(obj) - set(OBJECT_KEYS)
        if unknown:
            raise LevelError(f"{here}: unknown keys {sorted(unknown)} (known: {', '.join(OBJECT_KEYS)})")
        for key in ("name", "file"):
            _required(obj, key, str, here)
        for key, kind in OBJECT_KEYS.items():
            if key in obj and (not isinstance(obj[key], kind) or isinstance(obj[key], bool)):
                raise LevelError(f"{here}: '{key}' has the wrong type: {obj[key]!r}")
        if not obj.get("size", 1.0) > 0:
            raise LevelError(f"{here}: size must be positive, not {obj['size']!r}")
        for key in ("location", "color"):
            if key in obj and (len(obj[key]) != 3 or not all(isinstance(v, (int, float)) and
                                                               not isinstance(v, bool) for v in obj[key])):
                raise LevelError(f"{here}: '{key}' must be three numbers, not {obj[key]!r}")
        if obj["name"] in names:
            raise LevelError(f"{here}: a second object named {obj['name']!r}")
        names.add(obj["name"])
    return objects


def _table(data, key, where, optional=False):
    if key not in data and optional:
        return {}
    return _required(data, key, dict, where)


def validate_condition(condition, where):
    """Raises LevelError unless `condition` is one of the declarative forms of the module docstring."""
    if not isinstance(condition, dict) or not condition:
        raise LevelError(f"{where}: a condition must be a non-empty table, not {condition!r}")
    for combinator in ("all", "any"):
        if combinator in condition:
            parts = condition[combinator]
            if len(condition) != 1 or not isinstance(parts, list) or not parts:
                raise LevelError(f"{where}: '{combinator}' takes a non-empty list and nothing beside it")
            for part in parts:
                validate_condition(part, where)
            return
    kinds = {"property": COMPARISONS, "id_property": ID_PROPERTY_TESTS, "object": OBJECT_TESTS,
             "probe_pixel_near": PROBE_TESTS}
    kind = [k for k in kinds if k in condition]
    if len(kind) != 1:
        raise LevelError(f"{where}: a condition needs exactly one of {sorted(kinds)} (or all / any): "
                         f"{condition!r}")
    kind = kind[0]
    tests = [k for k in condition if k != kind]
    if len(tests) != 1 or tests[0] not in kinds[kind]:
        raise LevelError(f"{where}: '{kind}' takes exactly one of {list(kinds[kind])}: {condition!r}")
    if kind == "property":
        group, _, name = str(condition["property"]).partition(".")
        if group not in SETTING_GROUPS or not name.isidentifier() or name.startswith("_"):
            raise LevelError(f"{where}: property must be '<group>.<name>' (group: {', '.join(SETTING_GROUPS)}), "
                             f"not {condition['property']!r}")
    if kind in ("id_property", "probe_pixel_near"):
        path = condition[kind]
        if not isinstance(path, str) or not all(part for part in path.split(".")):
            raise LevelError(f"{where}: {kind} must name an ID property, dots between its keys: {path!r}")
    if kind == "id_property" and "decreased" in condition and condition["decreased"] is not True:
        raise LevelError(f"{where}: decreased takes true: {condition!r}")
    if kind == "probe_pixel_near" and (isinstance(condition["within"], bool)
                                       or not isinstance(condition["within"], int) or condition["within"] < 0):
        raise LevelError(f"{where}: within must be a whole number of pixels >= 0: {condition!r}")
    if kind == "object" and condition["object"] != "mesh":
        raise LevelError(f"{where}: only object = \"mesh\" (the level's mesh) is known")


IMAGE = re.compile(r"^!\[(?P<caption>[^\]]*)\]\((?P<path>[^)]+)\)$")


def read_text(path):
    """text.md as blocks for the panel: ("heading", text), ("paragraph", text), ("bullet", text),
    ("image", absolute path, caption). Markdown emphasis is dropped: Blender labels are plain."""
    if not os.path.isfile(path):
        raise LevelError(f"{path} is missing")
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    blocks, paragraph = [], []

    def flush():
        if paragraph:
            blocks.append(("paragraph", " ".join(paragraph)))
            paragraph.clear()

    for raw in lines:
        line = raw.strip()
        image = IMAGE.match(line)
        if not line:
            flush()
        elif line.startswith("#"):
            flush()
            blocks.append(("heading", plain(line.lstrip("#").strip())))
        elif line.startswith(("- ", "* ")):
            flush()
            blocks.append(("bullet", plain(line[2:])))
        elif image:
            flush()
            image_path = os.path.join(os.path.dirname(path), image["path"])
            if not os.path.isfile(image_path):
                raise LevelError(f"{path}: diagram {image['path']} does not exist")
            blocks.append(("image", image_path, plain(image["caption"])))
        elif blocks and blocks[-1][0] == "bullet" and not paragraph and raw.startswith("  "):
            blocks[-1] = ("bullet", blocks[-1][1] + " " + plain(line))  # a bullet's continuation line
        else:
            paragraph.append(plain(line))
    flush()
    return blocks


def plain(text):
    """Markdown as a Blender label shows it: no emphasis, no code marks, no comments (the kinds lists'
    markers, tools/kind_lists.py)."""
    return re.sub(r"(\*\*|\*|`)", "", re.sub(r"<!--.*?-->", "", text))


def load_level(folder):
    path = os.path.join(folder, "level.toml")
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise LevelError(f"{path} is missing") from None
    except tomllib.TOMLDecodeError as error:
        raise LevelError(f"{path}: not valid TOML: {error}") from None
    return Level(folder, data)


def levels_root():
    for root in LEVEL_ROOTS:
        if os.path.isdir(root):
            return root
    raise LevelError(f"no levels folder found (looked in {', '.join(LEVEL_ROOTS)})")


_cache = {}  # folder -> (mtimes, Level or LevelError)
_listings = {}  # root as asked (None: levels_root()) -> (levels, errors), as available_levels last read them


def _mtimes(folder):
    return tuple(os.path.getmtime(os.path.join(folder, n)) if os.path.exists(os.path.join(folder, n)) else 0
                 for n in ("level.toml", "text.md"))


def available_levels(root=None, from_memory=False):
    """(levels sorted by order, errors): a broken level is reported, never fatal for the others. A level
    whose files changed is read again.

    from_memory=True answers with what the last call read (the disk only when nothing was read yet): what
    a panel's draw asks. Every file-system call lets go of Python's interpreter lock, and a draw that lets
    go of it lets F12's job thread enter or leave the render engine in the middle of the draw, which leaves
    Blender refusing every operator (the F12 lock-up render_engine.py describes). The tasks' timer reads
    the disk twice a second, so an edited level still shows within half a second."""
    if from_memory and root in _listings:
        levels, errors = _listings[root]
        return list(levels), list(errors)
    asked, root = root, root or levels_root()
    levels, errors = [], []
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if not os.path.isdir(folder) or not os.path.exists(os.path.join(folder, "level.toml")):
            continue
        stamp = _mtimes(folder)
        if folder not in _cache or _cache[folder][0] != stamp:
            try:
                _cache[folder] = (stamp, load_level(folder))
            except LevelError as error:
                _cache[folder] = (stamp, error)
        item = _cache[folder][1]
        (errors if isinstance(item, LevelError) else levels).append(item)
    levels.sort(key=lambda level: (level.order, level.id))
    _listings[asked] = (levels, errors)
    return list(levels), list(errors)


def find_level(level_id, root=None, from_memory=False):
    """The level named level_id; from_memory as in available_levels."""
    levels, errors = available_levels(root, from_memory)
    for level in levels:
        if level.id == level_id:
            return level
    for error in errors:
        if f"{os.sep}{level_id}{os.sep}" in str(error):
            raise error
    raise LevelError(f"no level named {level_id!r} (known: {', '.join(l.id for l in levels)})")
