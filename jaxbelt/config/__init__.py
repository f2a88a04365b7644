"""Configuration: the drive specification (``spec``), its checks (``validate``), TOML files
(``toml``), the reference cases (``cases``) and ``build_drive``, which turns a spec into a ``Drive``.
Nothing in the numerics imports this package."""

from .._errors import ConfigError as ConfigError
from .build import build_drive as build_drive
from .cases import benchmark_a as benchmark_a
from .laws import law_from_spec as law_from_spec
from .spec import BeltSpec as BeltSpec, ContactSpec as ContactSpec, DriveSpec as DriveSpec
from .spec import PulleySpec as PulleySpec, SolverSpec as SolverSpec, TensionerSpec as TensionerSpec
from .toml import dump_toml as dump_toml, load_config as load_config, read_toml as read_toml
from .toml import get_key as get_key, set_key as set_key, spec_from_dict as spec_from_dict, valid_keys as valid_keys
from .belt import installed_state_definition as installed_state_definition
from .validate import validate_spec as validate_spec
