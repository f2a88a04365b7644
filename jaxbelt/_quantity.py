"""What a signal is: ``Quantity`` (prefix, unit, member, labels), shared by the signal registry
(``outputs.signals``) and the rooms that declare signals of their own (the carriers)."""

from __future__ import annotations

import dataclasses
import typing

__all__ = ["Quantity"]


@typing.final
@dataclasses.dataclass(frozen=True)
class Quantity:
    """One kind of signal: columns ``<prefix>:<member>`` in ``unit``; ``label`` and ``title`` for plots."""

    prefix: str
    unit: str
    member: str  # what follows the colon: a pulley, a span "<from>-<to>", a tensioner, a slider
    label: str
    title: str
    # An angle that wraps (its period in ``unit``): averaged as a circular mean, never as numbers.
    period: float | None = None
    # The circular mean's weight: the signal of this prefix and the same member (the angle's magnitude:
    # the mean is then the direction of the mean vector).
    magnitude: str | None = None

    @property
    def pattern(self) -> str:
        return f"{self.prefix}:<{self.member}>"

    @property
    def axis_label(self) -> str:
        return f"{self.label} [{self.unit}]"
