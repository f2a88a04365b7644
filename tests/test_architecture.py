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


# --- records instead of long argument lists ---

MOST_PARAMETERS = 8


def _parameter_count(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Positional-only, positional and keyword-only parameters, ``self``/``cls`` not counted (nor *args, **kw)."""
    a = fn.args
    n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
    first = (a.posonlyargs + a.args)[:1]
    return n - 1 if first and first[0].arg in ("self", "cls") else n


def _long_signatures(source: str) -> list[tuple[str, int, str]]:
    """(name, parameter count, docstring) of every function in ``source`` with more than MOST_PARAMETERS."""
    return [
        (node.name, _parameter_count(node), ast.get_docstring(node) or "")
        for node in ast.walk(ast.parse(source))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _parameter_count(node) > MOST_PARAMETERS
    ]


def test_no_function_takes_more_than_eight_parameters_without_a_reason():
    """Every function in jaxbelt/ takes at most eight parameters (self/cls not counted; positional and
    keyword-only), or its docstring gives the reason in a sentence starting "Parameters:" (a user's keyword
    options of one entry point, or a compiled function whose static options are part of its compilation key).
    Only the marker is checked, not the reason's content: related arguments belong in a record."""
    bad = [
        f"{path.relative_to(PACKAGE)}: {name} takes {n} parameters"
        for path in sorted(PACKAGE.rglob("*.py"))
        for name, n, doc in _long_signatures(path.read_text())
        if "Parameters:" not in doc
    ]
    assert not bad, "; ".join(bad) + ": group related arguments into a record, or say why not ('Parameters: ...')"


def test_the_parameter_count_leaves_out_self_and_counts_keyword_only_ones():
    source = (
        "class A:\n    def m(self, a, b, c, d, e, f, g, h): pass\n"
        "def f(a, b, /, c, d, *args, e, f, g, h, i, **kw):\n    'Parameters: why.'\n"
        "def g(a, b, c, d, e, f, g, h, i): pass\n"
    )
    assert [(name, n) for name, n, _ in _long_signatures(source)] == [("f", 9), ("g", 9)]
    assert [doc for *_, doc in _long_signatures(source)] == ["Parameters: why.", ""]
