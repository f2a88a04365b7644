"""The friction laws' own keys in the configuration, read generically from the laws' ``keys``.

Each law in ``contact.friction.FRICTION_LAWS`` declares its keys (``LawKey`` records). Here they
become, without naming any law:

- ``ContactSpec`` attributes and keyword arguments (``ContactSpec(mu_kinetic=0.4)``,
  ``spec.contact.mu_kinetic = 0.4``), stored in its one field ``law_parameters`` (``law_keys_as_attributes``);
- TOML keys of ``[contact]``, flat as before (``contact.mu_kinetic``; ``config.routed`` gives
  ``config/toml.py`` the schema with the law keys in place of ``law_parameters``);
- validation: the chosen law's keys checked by their own ``check``, other laws' keys refused
  (``check_law_keys``);
- the built law and its differentiable coefficients ``DriveParams.friction`` (``law_for``, ``law_arrays``).

The table is read at each call, so a law added to it (even at run time) is a valid name at once.
"""

from __future__ import annotations

from collections.abc import Callable

from ..contact.friction import FRICTION_LAWS, AbstractFrictionLaw, LawKey
from .routed import refuse_unknown, routed

__all__ = ["law_keys", "law_keys_as_attributes", "check_law_keys", "law_for", "law_arrays"]

FIELD = "law_parameters"  # the one ContactSpec field that holds the law keys


def law_keys() -> dict[str, list[str]]:
    """Every law key of the table (table order) -> names of the laws that declare it."""
    out: dict[str, list[str]] = {}
    for law_name, law in FRICTION_LAWS.items():
        for key in law.keys:
            out.setdefault(key.name, []).append(law_name)
    return out


def _defaults() -> dict[str, None]:
    return {k: None for k in law_keys()}  # a law key is absent unless given


def _hints() -> dict[str, type]:
    return {k: float for k in law_keys()}


# Class decorator (above ``@dataclass``): the law keys as keyword arguments and attributes of ``ContactSpec``
# (``ContactSpec(mu_kinetic=0.4)``, ``spec.contact.mu_kinetic = 0.4``), routed into its dict field
# ``law_parameters`` (``None`` removes a key: an unset optional key); ``friction_law`` one of the table's names.
law_keys_as_attributes = routed(FIELD, _defaults, _hints, {"friction_law": lambda: tuple(FRICTION_LAWS)})


def check_law_keys(contact, require: Callable) -> None:
    """Check ``contact.law_parameters`` against the chosen (already valid) law; ``require(cond, key, value,
    allowed)`` raises the configuration error. Keys are checked in table order, each: refused when the
    chosen law does not use it, else its own check (a missing required key is checked as None)."""
    given = getattr(contact, FIELD)
    require(isinstance(given, dict), f"contact.{FIELD}", given, "must be a dict of the friction law's keys")
    law_name = contact.friction_law
    own: dict[str, LawKey] = {k.name: k for k in FRICTION_LAWS[law_name].keys}
    owners = law_keys()
    for name, users in owners.items():
        value = given.get(name)
        if name not in own:
            require(
                value is None,
                f"contact.{name}",
                value,
                "is used only with contact.friction_law = " + " or ".join(map(repr, users)),
            )
        elif value is not None or own[name].required:
            msg = own[name].check(value, contact.mu)
            if own[name].required:
                msg = msg and f"{msg}; required with friction_law = {law_name!r}"
            require(msg is None, f"contact.{name}", value, msg)
    refuse_unknown(given, owners, "contact", "friction law", require)


def law_for(contact) -> AbstractFrictionLaw:
    """The law of a validated ``ContactSpec`` (static choices only, no numbers)."""
    return FRICTION_LAWS[contact.friction_law].from_values(dict(getattr(contact, FIELD)))


def law_arrays(contact, f64: Callable) -> dict:
    """``DriveParams.friction``: the given law keys of a validated ``ContactSpec`` as arrays."""
    return {k: f64(v) for k, v in getattr(contact, FIELD).items()}
