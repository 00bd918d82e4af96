"""The simulated world a saved map was made in, kept in the map's YAML.

``map_saver`` adds ``mrs_nav_world: PATH`` (the simulator's ``~world`` when one runs) to the map_server YAML it
writes; map_server ignores keys it does not know. ``navigation.launch map_file:=MAP`` then simulates that world
unless ``world:=`` is given (the simulator takes a map YAML as its world), and the map server warns once when the
simulated world and the map's differ: localising the arena's robot on the office's map cannot work, and nothing
else would say why.
"""

from __future__ import annotations

from pathlib import Path

from mrs_nav.errors import MapFileError
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.textfiles import load_yaml, read_text

#: The extra key of a map YAML naming its world.
WORLD_KEY = "mrs_nav_world"
_MAX_YAML_BYTES = 1 << 20


def world_path(name: str, worlds_dir: Path = WORLDS_DIR) -> Path:
    """A world file: a bare name (``office``, ``office.world``) is one of the package's worlds, else a path."""
    if "/" in name:
        return Path(name).expanduser()
    return worlds_dir / (name if name.endswith((".world", ".sdf")) else f"{name}.world")


def saved_world(map_yaml: Path) -> Path | None:
    """The world ``map_yaml`` was saved in (a relative path is taken from the YAML's folder), or None when the
    map does not say (saved by another tool, or with no simulator running)."""
    meta = load_yaml(read_text(map_yaml, _MAX_YAML_BYTES, "map description", MapFileError), str(map_yaml), MapFileError)
    name = meta.get(WORLD_KEY) if isinstance(meta, dict) else None
    if name is None:
        return None
    if not isinstance(name, str) or not name:
        raise MapFileError(f"{map_yaml}: {WORLD_KEY} must name a world file, got {name!r}")
    path = world_path(name)
    return path if path.is_absolute() else map_yaml.parent / path


def world_of_map(map_yaml: Path) -> Path:
    """The world to simulate for ``map_yaml``; a map that does not name one is an error saying what to give."""
    world = saved_world(map_yaml)
    if world is None:
        raise MapFileError(f"{map_yaml} does not name the world it was made in ({WORLD_KEY}); give world:=FILE")
    return world


def disagreement(map_yaml: Path, world: str) -> str | None:
    """One line when the simulated ``world`` is not the one ``map_yaml`` was saved in; None when they agree or
    the map does not say."""
    saved = saved_world(map_yaml)
    if saved is None or world.endswith(".yaml"):
        return None
    simulated = world_path(world)
    if simulated.resolve() == saved.resolve():
        return None
    return (
        f"the map {map_yaml} was made in {saved}, but the simulator runs {simulated}: "
        "the localisation will not find the robot on this map (give the map's world:=, or leave world:= out)"
    )
