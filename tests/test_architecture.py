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


# --- transitive: what a numerics module runs when imported or called reaches neither config nor analysis ---

UPPER = ("jaxbelt.config", "jaxbelt.analysis", "jaxbelt.cli")


def _runtime_imports(path: Path) -> list[str]:
    """Like ``_imported`` without the imports under ``if TYPE_CHECKING:`` (they never run)."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            node.body = [ast.Pass()]
    package = ["jaxbelt", *path.relative_to(PACKAGE).parent.parts]
    return _imported(ast.unparse(tree), package)


def _file_of(module: str) -> Path | None:
    rel = Path(*module.split(".")[1:])
    for candidate in (PACKAGE / rel.with_suffix(".py"), PACKAGE / rel / "__init__.py"):
        if module != "jaxbelt" and candidate.is_file():
            return candidate
    return None


def _module_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(("jaxbelt", *(parts[:-1] if parts[-1] == "__init__" else parts)))


def _reach(start: Path) -> dict[str, str]:
    """Every jaxbelt module ``start`` reaches through runtime imports (the root package's ``__init__`` left
    out: it imports everything), each with the module that imported it (for the message)."""
    seen = {_module_of(start): ""}
    todo = [start]
    while todo:
        path = todo.pop()
        here = _module_of(path)
        names = [m for m in _runtime_imports(path) if m.startswith("jaxbelt.")]
        parents = {".".join(m.split(".")[:k]) for m in names for k in range(2, m.count(".") + 1)}
        for m in sorted(set(names) | parents):
            f = _file_of(m)
            if f is not None and m not in seen:
                seen[m] = here
                todo.append(f)
    return seen


def _chain(seen: dict[str, str], m: str) -> str:
    out = [m]
    while seen[out[-1]]:
        out.append(seen[out[-1]])
    return " <- ".join(out)


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_numerics_reach_neither_config_nor_analysis_through_any_import(path):
    seen = _reach(path)
    bad = [m for m in seen if m.startswith(UPPER)]
    assert not bad, "; ".join(_chain(seen, m) for m in bad)


def test_the_transitive_check_follows_chains(tmp_path):
    """analysis.run imports config (directly or through others): the walk finds it with its chain."""
    seen = _reach(PACKAGE / "analysis" / "run.py")
    assert any(m.startswith("jaxbelt.config") for m in seen), sorted(seen)
    assert "jaxbelt" not in seen  # the root package is not followed
