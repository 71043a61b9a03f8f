"""The house's shape, read from the code's own imports (AST only: nothing is imported or run).

Data flows one way: the schema layer (``erc_schema``) → the codec's rooms, each importing only
the rooms below it (``BELOW``) and only their public names → the command lines; the linter
stands on ``erc_schema`` alone; no module imports a private name of another; no two modules
import each other, however indirectly.
"""

import ast
from collections.abc import Iterator
from pathlib import Path

from conftest import REPO

PACKAGES = ("erc_schema", "erc_codec", "erc_lint")


def modules() -> dict[str, Path]:
    """Dotted module name → file, for every module of both packages."""
    found = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = path.relative_to(REPO).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


MODULES = modules()


def is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def imports(name: str) -> Iterator[tuple[int, str, str | None]]:
    """``(line, module, imported name or None)`` of every import statement in a module,
    relative imports resolved, the ones inside functions included."""
    tree = ast.parse(MODULES[name].read_text(encoding="utf-8"))
    here = name.split(".") if is_package(name) else name.split(".")[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                target = ".".join([*base, *([node.module] if node.module else [])])
            else:
                target = node.module or ""
            for alias in node.names:
                yield node.lineno, target, alias.name


def edges() -> dict[str, set[str]]:
    """Module → the modules of both packages it imports (a name that is a module counts as it)."""
    graph: dict[str, set[str]] = {name: set() for name in MODULES}
    for name in MODULES:
        for _, target, imported in imports(name):
            full = f"{target}.{imported}" if imported else target
            dest = full if full in MODULES else target
            if dest in MODULES and dest != name:
                graph[name].add(dest)
    return graph


def test_no_module_imports_a_private_name_of_another() -> None:
    crossing = []
    for name in MODULES:
        for line, target, imported in imports(name):
            if imported is None or f"{target}.{imported}" in MODULES or target == name:
                continue
            if imported.startswith("_") and not imported.startswith("__"):
                crossing.append(f"{MODULES[name].relative_to(REPO)}:{line}: {imported}")
    assert crossing == []


def test_the_linter_uses_only_public_names_of_the_codec() -> None:
    reaching = []
    for name in MODULES:
        if not name.startswith("erc_lint"):
            continue
        for line, target, imported in imports(name):
            parts = [*target.split("."), *([imported] if imported else [])]
            if parts[0] in ("erc_codec", "erc_schema") and any(
                p.startswith("_") for p in parts[1:]
            ):
                reaching.append(f"{MODULES[name].relative_to(REPO)}:{line}: {'.'.join(parts)}")
    assert reaching == []


def test_the_codec_never_depends_on_its_linter() -> None:
    graph = edges()
    assert [
        (n, d)
        for n in MODULES
        if n.startswith("erc_codec")
        for d in graph[n]
        if d.startswith("erc_lint")
    ] == []


def test_the_schema_layer_stands_on_its_own() -> None:
    """erc_schema imports nothing of erc_codec or erc_lint, and erc_lint nothing of erc_codec."""
    graph = edges()
    assert [
        (n, d)
        for n in MODULES
        for d in graph[n]
        if (n.startswith("erc_schema") and not d.startswith("erc_schema"))
        or (n.startswith("erc_lint") and d.startswith("erc_codec"))
    ] == []


# Each room and the rooms it may import: only ones below it. erc_codec itself (its __init__, the
# face) re-exports the codec room; the command lines are the top.
_CORE = {"erc_schema", "erc_codec.schema", "erc_codec.codec"}
BELOW = {
    "erc_schema": set(),
    "erc_codec.schema": {"erc_schema"},
    "erc_codec.codec": {"erc_schema"},
    "erc_codec.runtime": _CORE,
    "erc_codec.strategies": _CORE,
    "erc_codec.transport": _CORE | {"erc_codec.runtime"},
    "erc_codec.capture": _CORE | {"erc_codec.runtime"},
    "erc_codec.proton": _CORE | {"erc_codec.runtime"},
    "erc_codec": _CORE | {"erc_codec.runtime", "erc_codec.transport", "erc_codec.capture"},
    "erc_codec.cli": {
        *_CORE,
        *("erc_codec.runtime", "erc_codec.transport", "erc_codec.capture", "erc_codec.proton"),
    },
    "erc_codec.__main__": {"erc_codec.cli"},
    "erc_lint": {"erc_schema"},
}


def room(module: str) -> str | None:
    """The room a module belongs to: the longest room name that is it or a package above it
    (``erc_codec`` itself is the face, no package above anything)."""
    if module == "erc_codec":
        return module
    found = [r for r in BELOW if r != "erc_codec" and (module == r or module.startswith(r + "."))]
    return max(found, key=len) if found else None


def test_every_module_is_in_a_room() -> None:
    assert room("erc_codec.oops") is None  # a module beside the rooms has none
    assert [m for m in MODULES if room(m) is None] == []


def test_a_room_imports_only_the_rooms_below_it() -> None:
    graph = edges()
    upward = [
        f"{name} -> {dest}"
        for name in MODULES
        for dest in graph[name]
        if room(dest) != room(name) and room(dest) not in BELOW.get(room(name) or "", set())
    ]
    assert upward == []


def test_a_room_uses_only_the_public_names_of_the_others() -> None:
    """Proton and every room below the command line reach another room through its package's
    names, never its private modules; the command line may use a room's helpers."""
    reaching = [
        f"{MODULES[name].relative_to(REPO)}:{line}: {target}"
        for name in MODULES
        if room(name) not in ("erc_codec.cli", "erc_codec.__main__")
        for line, target, _ in imports(name)
        if target.startswith("erc_")
        and room(target) != room(name)
        and any(part.startswith("_") for part in target.split("."))
    ]
    assert reaching == []


def test_the_core_never_imports_the_command_line() -> None:
    shell = (".cli", ".__main__")
    core = [n for n in MODULES if n.startswith("erc_codec") and not any(s in n for s in shell)]
    graph = edges()
    assert [(name, d) for name in core for d in graph[name] if ".cli" in d] == []


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (a package's __init__, which may
    import its own modules, does not count as one), by Tarjan's algorithm without recursion."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, pending = work[-1]
            step = next(pending, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = len(index)
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(graph[step]))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len([m for m in component if not is_package(m)]) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_cycles() -> None:
    assert cycles(edges()) == []


def test_the_cycle_finder_finds_cycles() -> None:
    """The check above proves something only if it can fail."""
    graph = {
        "erc_codec.codec._codec": {"erc_codec.codec._envelope"},
        "erc_codec.codec._envelope": set(),
    }
    assert cycles(graph) == []
    graph["erc_codec.codec._envelope"].add("erc_codec.codec._codec")
    assert cycles(graph) == [["erc_codec.codec._codec", "erc_codec.codec._envelope"]]
