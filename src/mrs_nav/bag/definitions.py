"""Each bag connection decoded by its own message definition, never by a layout it was not written with.

A ROS 1 bag stores, per connection, the full message definition and its md5sum. When the md5 is Noetic's, the
message is decoded with Noetic's types (:func:`mrs_nav.bag.io.typestore`). Otherwise the types are built from
the connection's own definition; the bag is read with them when that definition hashes to the stored md5 and
has the fields mrs_nav reads (the same names and types, perhaps in another order: fields are then read by
name, so values land where they belong). Any other connection is refused with one line naming topic, type and
md5: a message is never decoded with a layout it was not written in.
"""

from __future__ import annotations

import functools
from typing import Any

from rosbags.interfaces import Connection
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from mrs_nav.errors import BagError


def connection_store(conn: Connection, noetic: Any, bag: object) -> Any:
    """The type store to decode ``conn``'s messages with (``noetic`` when its md5 is Noetic's); :class:`BagError`
    naming ``bag``, topic, type and md5 when no store reads it as written."""
    expected = noetic.generate_msgdef(conn.msgtype)[1]
    if conn.digest == expected:
        return noetic
    own, why = _own_store(conn.msgtype, conn.msgdef.data, conn.digest)
    if own is not None and not _same_fields(noetic, own, conn.msgtype):
        own, why = None, "its definition has other fields than Noetic's"
    if own is None:
        raise BagError(
            f"bag {bag}: topic {conn.topic} has type {conn.msgtype} with md5 {conn.digest}, not Noetic's {expected}, "
            f"and {why}: mrs_nav cannot read it as written"
        )
    return own


@functools.cache
def _own_store(msgtype: str, msgdef: str, digest: str) -> tuple[Any, str]:
    """A type store built from a connection's definition, or ``None`` and why not."""
    if not msgdef.strip():
        return None, "the bag holds no definition for it"
    store = get_typestore(Stores.EMPTY)
    try:
        store.register(get_types_from_msg(msgdef, msgtype))
        own_digest = store.generate_msgdef(msgtype)[1]
    except Exception as err:  # rosbags raises several kinds on a malformed definition
        return None, f"its definition cannot be parsed ({' '.join(str(err).split())})"
    if own_digest != digest:
        return None, f"its definition hashes to {own_digest}, not to the md5 stored with it"
    return store, ""


def _same_fields(noetic: Any, own: Any, msgtype: str) -> bool:
    """Whether ``msgtype`` has the same field names and types, recursively, in both stores (order aside)."""
    ours, theirs = dict(noetic.fielddefs[msgtype][1]), dict(own.fielddefs.get(msgtype, ((), ()))[1])
    return ours.keys() == theirs.keys() and all(_same_type(noetic, own, ours[k], theirs[k]) for k in ours)


def _same_type(noetic: Any, own: Any, ours: tuple[Any, Any], theirs: tuple[Any, Any]) -> bool:
    """Two rosbags field descriptors: ``(kind, a message type's name | (base name, bound) | (element, size))``."""
    if ours[0] != theirs[0]:
        return False
    if isinstance(ours[1], str):
        return bool(ours[1] == theirs[1] and _same_fields(noetic, own, ours[1]))
    if isinstance(ours[1][0], str):
        return bool(ours[1] == theirs[1])
    return bool(ours[1][1] == theirs[1][1] and _same_type(noetic, own, ours[1][0], theirs[1][0]))
