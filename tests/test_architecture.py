"""The numerics never import the configuration: belt/, geometry/, pulleys/, contact/, dynamics/ and
outputs/ read a built ``Drive`` (jaxbelt._drive) and the model types, never ``jaxbelt.config``."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "jaxbelt"
NUMERICS = ("belt", "geometry", "pulleys", "contact", "dynamics", "outputs")


def _imported(source: str, package: list[str]) -> list[str]:
    """Absolute names of every module ``source`` (a module of ``package``) imports, relative imports
    resolved, at any depth (function-level and TYPE_CHECKING imports included); ``from a import b``
    counts as ``a`` and ``a.b`` (b may be a module)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            out += [module] + [f"{module}.{alias.name}" for alias in node.names]
    return out


def _imports_config(names: list[str]) -> list[str]:
    return [m for m in names if m == "jaxbelt.config" or m.startswith("jaxbelt.config.")]


def _modules():
    return sorted(p for room in NUMERICS for p in (PACKAGE / room).rglob("*.py"))


def test_every_room_is_checked():
    rooms = {p.relative_to(PACKAGE).parts[0] for p in _modules()}
    assert rooms == set(NUMERICS)


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_numerics_do_not_import_config(path):
    package = ["jaxbelt", *path.relative_to(PACKAGE).parent.parts]
    bad = _imports_config(_imported(path.read_text(), package))
    assert not bad, f"{path.relative_to(PACKAGE)} imports {bad}: numerics must not import jaxbelt.config"


@pytest.mark.parametrize(
    "line",
    [
        "from ..config.build import Drive",
        "from .. import config",
        "import jaxbelt.config.toml",
        "from jaxbelt.config import build_drive",
        "def f():\n    from ..config import spec",
    ],
)
def test_the_check_sees_every_form_of_import(line):
    assert _imports_config(_imported(line, ["jaxbelt", "outputs"]))


def test_the_check_passes_sibling_imports():
    assert not _imports_config(
        _imported(
            "from .._drive import Drive\nfrom ..geometry.path import belt_path\nfrom .energy import energy_audit",
            ["jaxbelt", "outputs"],
        )
    )
