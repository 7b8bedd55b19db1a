"""A gripper file read as MuJoCo reads it, but as a part of a scene (:func:`load_gripper_spec`):
the scene's angle unit where the file sets none, its ``<include>`` files read from its own folder,
a repeated asset or an attribute this MuJoCo does not know left out, with a warning.  The first
of a mount's jobs (:mod:`cosim.gripper_mount`)."""

from __future__ import annotations

import functools
import re
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco


class GripperFileWarning(UserWarning):
    """A gripper file read otherwise than MuJoCo would read it alone (:func:`load_gripper_spec`)."""


# ---------------------------------------------------------------------------------------
# The file.
# ---------------------------------------------------------------------------------------


def load_gripper_spec(path: str | Path, warn: bool = True) -> mujoco.MjSpec:
    r"""The gripper file as an MjSpec, read as a part of the scene (a fresh spec each call).

    Rules for a file written as a part of a larger model (robosuite's grippers are merged into a
    world whose ``<compiler angle="radian">`` they rely on, by a merge that passes any XML):

    - a file that sets no ``<compiler angle>`` is read in the scene's unit, radians
      (models/gripper.xml's), as a file ``<include>``\ d in the scene would be; MuJoCo reads a
      file alone in degrees, which would shrink a joint range of 0.8 rad to 0.8 degrees;
    - an asset (mesh, texture, material, ...) named twice keeps its first definition, as
      robosuite's merge keeps it; MuJoCo refuses the second;
    - an attribute this MuJoCo does not know (such a merge lets one through, on a ``<default>``
      say) is left out; MuJoCo refuses the file;
    - a body without a name is named ``body<i>``, i its place among the file's bodies (``_<n>``
      appended where the file has that name already): the mount names the gripper's bodies in the scene (the pads'
      contact exclusions, the fingers' force sensors), and MuJoCo finds an unnamed one by no name
      (robosuite's Fourier hands hang their palm from one).  Nothing else changes.

    Each repair comes with a :class:`GripperFileWarning` naming it (with ``warn``;
    tests/test_third_party_grippers.py::test_a_gripper_file_loads_as_a_part_of_the_scene).

    Raises
    ------
    ValueError
        naming ``gripper.mjcf`` and the file: missing, not XML, or refused by MuJoCo.
    """
    key = _file_key(path)
    text, repairs, has_angle, directory, includes = _read_file(*key)
    for repair in repairs if warn else ():
        warnings.warn(f"gripper.mjcf {str(path)!r}: {repair}", GripperFileWarning, 2)
    if repairs:
        spec = mujoco.MjSpec.from_string(text, include=dict(includes))
        spec.modelfiledir = directory
    else:
        # MuJoCo's own reading where nothing needs repair: its includes and their compiler's
        # folders as MuJoCo resolves them (Gymnasium-Robotics' Franka kitchen includes
        # ../franka_assets/assets.xml, whose meshdir the including file sets again; read from a
        # string with its includes given, the meshes were looked for in a folder that is not there).
        spec = mujoco.MjSpec.from_file(key[0])
    if not has_angle:
        spec.compiler.degree = False
    _name_unnamed_bodies(spec)
    return spec


def _name_unnamed_bodies(spec: mujoco.MjSpec) -> None:
    """Name each unnamed body of ``spec`` but the world ``body<i>``, i its place among the spec's
    bodies (the compiled model's index where the file replicates none), ``_<n>`` appended where
    taken: a name to find it by, the same at every reading of the file."""
    bodies = list(spec.bodies)
    taken = {body.name for body in bodies}
    for index, body in enumerate(bodies[1:], start=1):
        if body.name:
            continue
        name, n = f"body{index}", 1
        while name in taken:
            name, n = f"body{index}_{n}", n + 1
        body.name = name
        taken.add(name)


def _file_key(path: str | Path) -> tuple[str, int, int]:
    """(resolved path, modification time, size): what the file's readings are cached by."""
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"gripper.mjcf: no file {str(path)!r}")
    stat = file.stat()
    return str(file.resolve()), stat.st_mtime_ns, stat.st_size


#: MuJoCo's words for an attribute it does not know: the attribute, the element and its line.
_UNKNOWN_ATTRIBUTE = re.compile(r"unrecognized attribute: '([^']+)'\s*Element '([^']+)', line (\d+)")
#: The most repairs a file gets before it counts as no MJCF at all.
_MAX_REPAIRS = 32


#: The most ``<include>`` files a gripper file may bring in (nested ones counted), a guard.
_MAX_INCLUDES = 64


def _included_files(path: str, root: ET.Element) -> dict[str, bytes]:
    """The files ``<include file=...>`` elements of the file at ``path`` (parsed: ``root``) bring
    in, nested ones too, read as MuJoCo reads them when it loads that file: from the including
    file's folder, else the gripper file's (a string parsed elsewhere would look in the working
    folder: the wrong file, or none).  Keyed by the name as written (MuJoCo looks a nested name
    up either way).  A ValueError names the gripper file and the include that cannot be read."""
    top = Path(path).parent
    found: dict[str, bytes] = {}
    pending = [(root, top)]
    while pending:
        element_root, folder = pending.pop()
        for element in element_root.iter("include"):
            name = element.get("file")
            if name is None or name in found:
                continue
            if len(found) >= _MAX_INCLUDES:
                raise ValueError(f"gripper.mjcf {path!r} includes more than {_MAX_INCLUDES} files")
            candidates = [folder / name, top / name] if folder != top else [top / name]
            file = next((c for c in candidates if c.is_file()), candidates[0])
            try:
                found[name] = file.read_bytes()
                pending.append((ET.fromstring(found[name]), file.parent))
            except (OSError, ET.ParseError) as err:
                raise ValueError(f"gripper.mjcf {path!r}: its <include file={name!r}> (in {str(folder)!r}) cannot be read: {err}") from None
    return found


@functools.lru_cache(maxsize=32)
def _read_file(path: str, mtime_ns: int, size: int) -> tuple[str, tuple[str, ...], bool, str, tuple[tuple[str, bytes], ...]]:
    """The file's text as MuJoCo takes it (load_gripper_spec's repairs made), the repairs, whether
    it sets its compiler's angle unit, its directory, and the files it includes (name, contents;
    read from its directory: :func:`_included_files`)."""
    try:
        text = Path(path).read_text()
        root = ET.fromstring(text)
    except (ET.ParseError, OSError, UnicodeDecodeError) as err:
        raise ValueError(f"gripper.mjcf {path!r} is no XML file: {err}") from None
    includes = _included_files(path, root)
    repairs: list[str] = []
    for _ in range(_MAX_REPAIRS):
        try:
            mujoco.MjSpec.from_string(text, include=includes)  # parsed only: its meshes are read when compiled
            break
        except Exception as err:  # MuJoCo raises ValueError; name the file whatever it raises
            message = str(err)
            unknown = _UNKNOWN_ATTRIBUTE.search(message)
            if unknown is not None and (fixed := _without_attribute(text, *unknown.groups())) is not None:
                text = fixed
                attribute, element, line = unknown.groups()
                repairs.append(
                    f"attribute {attribute!r} of <{element}> on line {line} left out (MuJoCo {mujoco.__version__} does not know it)"
                )
            elif "repeated name" in message and not any("defined twice" in r for r in repairs):
                text, repeated = _first_assets(text)
                repairs += [f"{what} is defined twice: the first kept (robosuite's rule)" for what in repeated]
                if not repeated:
                    raise ValueError(f"gripper.mjcf {path!r} does not load: {err}") from None
            else:
                raise ValueError(f"gripper.mjcf {path!r} does not load: {err}") from None
    else:
        raise ValueError(f"gripper.mjcf {path!r} does not load: more than {_MAX_REPAIRS} attributes MuJoCo does not know")
    roots = [root, *(ET.fromstring(contents) for contents in includes.values())]
    has_angle = any(c.get("angle") is not None for r in roots for c in r.iter("compiler"))
    return text, tuple(repairs), has_angle, str(Path(path).parent), tuple(includes.items())


def _without_attribute(text: str, attribute: str, element: str, line: str) -> str | None:
    """``text`` without ``attribute`` on line ``line`` (1-based) of an ``element`` tag, or None."""
    lines = text.splitlines(keepends=True)
    index = int(line) - 1
    if not 0 <= index < len(lines) or f"<{element}" not in lines[index]:
        return None
    fixed = re.sub(rf"\s{re.escape(attribute)}\s*=\s*(\"[^\"]*\"|'[^']*')", "", lines[index], count=1)
    if fixed == lines[index]:
        return None
    return "".join([*lines[:index], fixed, *lines[index + 1 :]])


def _first_assets(text: str) -> tuple[str, list[str]]:
    """``text`` with each asset named twice kept once (its first definition), and which."""
    root = ET.fromstring(text)
    repeated = []
    for assets in root.iter("asset"):
        seen = set()
        for element in list(assets):
            key = (element.tag, element.get("name"))
            if key[1] is not None and key in seen:
                assets.remove(element)
                repeated.append(f"{key[0]} {key[1]!r}")
            seen.add(key)
    return ET.tostring(root, encoding="unicode"), repeated
