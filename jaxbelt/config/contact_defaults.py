"""The default normal contact stiffness of a belt, from its section.

The penalty law stands for the belt's radial compliance: the rubber between its tension cord and the
pulley is compressed by the contact pressure p (per unit belt length) by ``delta = p / k``. A layer of
compression modulus ``E_c`` and compressible thickness ``h_c`` has the stiffness ``E_c / h_c`` per unit of
contact area, and ``k = (E_c / h_c) b`` per unit length over the contact width ``b``:

* a flat belt: ``b = belt.width``;
* a poly-V belt: ``b = belt.width``, the ribs' projected width (ribs x rib pitch, 3.56 mm for PK); the
  ribs and the cushion above them (ISO 9981: PK ribs about 2 mm high) are that layer; the wedge's own
  geometry (pressure on the flanks) is not modelled.

``CONTACT_STIFFNESS_PER_AREA`` = 4e9 N/m^3 is Benchmark A's value per contact area (Ntarladima, Pieber,
Gerstmayr, Nonlinear Dynamics 2023: 3.2e8 N/m^2 over its 0.08 m width), i.e. a belt compound of
E_c = 10 MPa over h_c = 2.5 mm; belt rubbers (EPDM, CR; 5-15 MPa) over 1.5-3 mm give 2e9-1e10.
"""

from __future__ import annotations

CONTACT_STIFFNESS_PER_AREA = 4.0e9  # [N/m^3]


def default_contact_stiffness(contact, belt) -> float:
    """``contact.stiffness`` if given, else ``stiffness_per_area`` (or ``CONTACT_STIFFNESS_PER_AREA``) x
    ``belt.width`` [N/m^2]; both checked by validation before."""
    if contact.stiffness is not None:
        return float(contact.stiffness)
    per_area = CONTACT_STIFFNESS_PER_AREA if contact.stiffness_per_area is None else contact.stiffness_per_area
    return float(per_area) * float(belt.width)
