"""Named codes: the contact state of a belt point and the fault code of a run.

Both are ``IntEnum`` so they compare equal to (and mix into numpy / jnp expressions as) the plain
integers stored in arrays and files: ``state == ContactState.STICK`` on a ``contact_distribution``
array, ``DriveState.fault`` (a float: 0.0, 1.0, 2.0) against ``Fault.NONFINITE``.
"""

from __future__ import annotations

import enum

__all__ = ["ContactState", "Fault"]


class ContactState(enum.IntEnum):
    """State of a contact point: not touching, sticking, or slipping at the friction bound."""

    FREE = 0
    STICK = 1
    SLIP = 2

    @property
    def message(self) -> str:
        return _CONTACT_MESSAGES[self]


class Fault(enum.IntEnum):
    """Why a run stopped early (``DriveState.fault``); ``OK`` when it did not."""

    OK = 0
    NONFINITE = 1
    PENETRATION = 2   # belt penetrated a pulley by more than its allowance

    @property
    def message(self) -> str:
        return _FAULT_MESSAGES[self]


_CONTACT_MESSAGES = {ContactState.FREE: "free", ContactState.STICK: "stick", ContactState.SLIP: "slip"}
_FAULT_MESSAGES = {Fault.OK: "ok", Fault.NONFINITE: "non-finite state",
                   Fault.PENETRATION: "belt penetrated a pulley"}
