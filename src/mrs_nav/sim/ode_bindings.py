"""Safe use of ``python3-pyode`` (bindings 1.2.0.dev15) over libode 0.16: corrected constants, loud callbacks.

Three traps of these bindings (see PLATFORM.md), handled here once for the physics:

* the joint-parameter constants predate ODE 0.16, which inserted LoVel/HiVel after Vel, so ``ode.ParamFMax``
  sets the wrong parameter and a motor silently never moves: the library's values are defined below;
* the contact flags Slip1/Slip2/Approx1 are stale in the same way;
* an exception raised inside a ``collide``/``collide2`` near-callback is printed and swallowed, so the step
  goes on without the contacts: :func:`collide_spaces` re-raises it after the call.

A fourth needs care by the caller: a geom whose Python object is garbage-collected is destroyed and silently
leaves its space, so every geom must stay referenced by its owner.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import ode

# libode 0.16 joint parameters (dParamX for the first axis; second and third axis: + 0x100, + 0x200).
PARAM_LO_STOP = 0
PARAM_HI_STOP = 1
PARAM_VEL = 2
PARAM_FMAX = 5
# libode 0.16 contact mode flags. SoftERP/SoftCFM/Mu2 in the bindings are right.
CONTACT_SOFT_ERP = int(ode.ContactSoftERP)
CONTACT_SOFT_CFM = int(ode.ContactSoftCFM)
CONTACT_SLIP1 = 0x100
CONTACT_SLIP2 = 0x200
CONTACT_APPROX1 = 0x7000  # friction pyramid scaled by the normal force, both directions


def collide_spaces(first: Any, second: Any, near: Callable[[Any, Any], None]) -> None:
    """Call ``near(g1, g2)`` for every geom pair of ``first`` x ``second`` whose bounding boxes overlap.

    Unlike a bare ``ode.collide2``, an exception raised by ``near`` propagates to the caller.
    """
    errors: list[BaseException] = []

    def guarded(_: object, g1: Any, g2: Any) -> None:
        if errors:
            return
        try:
            near(g1, g2)
        except BaseException as err:  # re-raised below: pyode would print and drop it
            errors.append(err)

    ode.collide2(first, second, None, guarded)
    if errors:
        raise errors[0]
