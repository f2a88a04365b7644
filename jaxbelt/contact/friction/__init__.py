"""Friction laws of the contact solve, as types, and the table of their configuration names.

Adding a law: one module here (a subclass of ``AbstractFrictionLaw`` declaring its ``keys``) and one
line in ``FRICTION_LAWS``. Validation, the TOML keys, ``ContactSpec`` attributes, ``DriveParams.friction``
and ``set_parameter`` keys all follow from the law's ``keys`` (see ``jaxbelt/config/friction_keys.py``).
"""

from __future__ import annotations

from .base import AbstractFrictionLaw as AbstractFrictionLaw, LawKey as LawKey
from .base import is_finite_number as is_finite_number, positive as positive
from .coulomb import Coulomb as Coulomb
from .regularised import Regularised as Regularised
from .static_kinetic import StaticKinetic as StaticKinetic

# contact.friction_law name -> class: build_drive validates against and constructs from this table.
FRICTION_LAWS: dict[str, type[AbstractFrictionLaw]] = {
    "coulomb": Coulomb,
    "regularized": Regularised,
    "static-kinetic": StaticKinetic,
}
