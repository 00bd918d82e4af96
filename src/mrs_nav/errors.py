"""Exceptions shared by the core library.

Every error the core raises on bad input derives from :class:`MrsNavError`, so the command line and the nodes
can turn it into one clear line without catching unrelated bugs.
"""


class MrsNavError(Exception):
    """Base class for errors caused by the caller's input or files."""


class InvalidInputError(MrsNavError, ValueError):
    """A number, pose, goal, obstacle list or parameter is malformed or out of range."""


class WorldFileError(MrsNavError):
    """A world file cannot be read or holds something the simulator cannot honour."""


class MapFileError(MrsNavError):
    """A map_server map (.yaml + .pgm) cannot be read or written."""


class BagError(MrsNavError):
    """A bag is unreadable, truncated, or lacks the topics a tool needs."""


class NoPathFoundError(MrsNavError):
    """A planner ended without a path to the goal: its budget was used up, or the obstacles close the goal off.

    The message is the reason. ``time_s`` (s), ``iterations`` and ``nodes`` tell what the search spent before it
    gave up (0 when it gave up before searching), for the command line and benchmarks; there is no path.
    """

    def __init__(self, reason: str, *, time_s: float = 0.0, iterations: int = 0, nodes: int = 0) -> None:
        super().__init__(reason)
        self.reason = reason
        self.time_s = time_s
        self.iterations = iterations
        self.nodes = nodes


class OutputFileError(MrsNavError):
    """An output cannot be written (full disk, read-only folder, no permission) or would overwrite an input."""
