"""What a tree, or every revision of a git history, adds to a number ledger.

Guarantees:
- ``--history`` visits every commit reachable from the ref, each after its parents, so an entry's
  revision is the first commit (in that order) whose tree carried it, on whichever branch.
- A file is compiled again only when its text changed or what its imports define changed (the
  symbols of every file it imports, directly or not: names and kinds of messages, enums with
  their values, extensions with their types, packages and syntax; a descriptor takes nothing
  else from its imports, save the fields of a message used in an aggregate custom option).
  Results are cached by blob id and those definitions; a compilation gets the files it imports
  as descriptors, so protoc parses one file, not the chain behind it. A history whose revisions
  each add a field costs about one small compilation a revision.
- A file that does not compile in a revision (or imports one that does not, or imports itself)
  records nothing for that revision; the others do.
"""

import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path

from google.protobuf import descriptor_pb2

from erc_schema import (
    Declaration,
    GitSpec,
    ProtocError,
    Repository,
    compile_files,
    declarations,
    extensions,
    imports,
    services,
)

from ._ledger import Entry, Key, Ledger
from ._loader import by_basename, matches, respell, utf8_name
from ._model import type_of

__all__ = ["History", "keys", "recorded"]

_FileProto = descriptor_pb2.FileDescriptorProto
_Definitions = frozenset[tuple[object, ...]]  # the symbols a file and its imports define


def _never(path: str) -> bool:
    return False


def keys(files: Iterable[_FileProto], leftover: Callable[[str], bool] = _never) -> set[Key]:
    """What the ledger records of compiled files: every field and enum value number (see
    ``recorded``)."""
    return recorded(files, leftover)[0]


def recorded(
    files: Iterable[_FileProto], leftover: Callable[[str], bool] = _never
) -> tuple[set[Key], set[str]]:
    """What the ledger records of compiled files, and the names it records nothing of: a
    message or enum that two files of the revision define (a NAME_COLLISION: which one a build
    means is unknown) has no body recorded, unless all but one of them are in ``leftover``
    files (those ``ignore_only`` names for NAME_COLLISION)."""
    found: set[Key] = set()
    declared_in: dict[str, list[tuple[str, Declaration]]] = {}
    for file in files:
        for declared in declarations(file):
            declared_in.setdefault(declared.name, []).append((file.name, declared))
    collided = set()
    for name, alike in declared_in.items():
        counted = [d for path, d in alike if not leftover(path)] or [d for _, d in alike]
        if len(counted) > 1:
            collided.add(name)
            continue
        element = counted[0].proto
        if isinstance(element, descriptor_pb2.DescriptorProto):
            found.update(
                Key("message", name, f.number, f.name, type_of(f)[0]) for f in element.field
            )
        else:
            found.update(Key("enum", name, v.number, v.name, "-") for v in element.value)
    return found, collided


@dataclass(frozen=True)
class _Result:
    """One file compiled in the context of one revision (``proto`` None: it did not compile)."""

    proto: _FileProto | None
    keys: frozenset[Key] = frozenset()
    defines: _Definitions | None = None  # what importers can see; None when it did not compile


_FAILED = _Result(None)


@dataclass
class History:
    """Walks revisions of one git input, compiling only what changed since the last one."""

    repository: Repository
    spec: GitSpec
    includes: Sequence[Path] = ()
    exclude: Sequence[str] = ()
    leftovers: Sequence[str] = ()  # ignore_only's patterns for NAME_COLLISION: see ``recorded``
    compiled: int = 0  # files compiled so far, for the benchmark's report
    failed: set[str] = field(default_factory=set)  # files of the last revision that did not compile
    collided: set[str] = field(default_factory=set)  # names of the last revision not recorded
    _cache: dict[tuple[object, ...], _Result] = field(default_factory=dict)
    _imports: dict[str, list[tuple[int, int, str]]] = field(default_factory=dict)  # by blob

    def update(self, ledger: Ledger, commits: Sequence[str]) -> list[Entry]:
        """Add every revision of ``commits`` (parents first) to ``ledger``; the new entries."""
        added: list[Entry] = []
        inside, _ = self.repository.where(self.spec.subdir)
        with tempfile.TemporaryDirectory(prefix="erc-lint-history-") as scratch:
            for commit in commits:
                files = self.repository.files(commit, inside, missing_ok=True)
                added += ledger.add(self._keys(files, Path(scratch)), commit[:12])
        return added

    def _keys(self, files: dict[str, str], scratch: Path) -> set[Key]:
        protos = {
            path: blob
            for path, blob in files.items()
            if path.endswith(".proto") and utf8_name(path)
        }
        targets = self._targets(protos)
        results: dict[str, _Result] = {}
        for path in _ordered(targets):
            deps = targets[path]
            seen = tuple(
                (target, results[target].defines if target in results else None)
                for _, target in deps
            )
            key = (path, protos[path], seen)
            result = self._cache.get(key)
            if result is None:
                broken = any(target in protos and defines is None for target, defines in seen)
                result = _FAILED if broken else self._compile(path, protos, deps, results, scratch)
                self._cache[key] = result
            results[path] = result
        self.failed = {path for path in protos if results.get(path, _FAILED).proto is None}
        owners: dict[str, set[str]] = {}  # container → the files defining it
        for path, result in results.items():
            for found_key in result.keys:
                owners.setdefault(found_key.container, set()).add(path)
        counted = {
            container: {p for p in paths if not self._leftover(p)} or paths
            for container, paths in owners.items()
        }
        # Two files of the revision define one name (a NAME_COLLISION): neither body is its.
        self.collided = {container for container, paths in counted.items() if len(paths) > 1}
        return {
            key
            for path, result in results.items()
            if not any(fnmatchcase(path, pattern) for pattern in self.exclude)
            for key in result.keys
            if counted[key.container] == {path}
        }

    def _leftover(self, path: str) -> bool:
        return any(fnmatchcase(path, pattern) for pattern in self.leftovers)

    def _targets(self, protos: dict[str, str]) -> dict[str, list[tuple[str, str]]]:
        """Each file's imports as ``(spelling, what it names)``: a tree path when it resolves to
        exactly one file of the tree, else the spelling (for protoc's include folders)."""
        index = by_basename(protos)
        targets = {}
        for path, blob in protos.items():
            spans = self._imports.get(blob)
            if spans is None:
                text = self.repository.read(blob, name=str(self.spec.shown / path))
                spans = self._imports[blob] = list(imports(text.decode("utf-8", "replace")))
            found = []
            for _, _, spelling in spans:
                if spelling not in protos and any((d / spelling).is_file() for d in self.includes):
                    found.append((spelling, spelling))  # an -I folder's file, as protoc finds it
                    continue
                named = [spelling] if spelling in protos else matches(spelling, protos, index)
                found.append((spelling, named[0] if len(named) == 1 else spelling))
            targets[path] = found
        return targets

    def _compile(
        self,
        path: str,
        protos: dict[str, str],
        deps: list[tuple[str, str]],
        results: dict[str, _Result],
        scratch: Path,
    ) -> _Result:
        """Compile ``path`` alone, its imports respelled as tree paths and given compiled."""
        self.compiled += 1
        shown = str(self.spec.shown / path)
        text = self.repository.read(protos[path], name=shown).decode("utf-8", "replace")
        respelled = dict(deps)
        text = respell(
            text,
            [
                (start, end, respelled[spelling])
                for start, end, spelling in self._imports[protos[path]]
                if respelled.get(spelling, spelling) != spelling
            ],
        )
        known = descriptor_pb2.FileDescriptorSet()
        done: set[str] = set()
        pending = [target for _, target in deps if target in results]
        while pending:
            name = pending.pop()
            proto = results[name].proto if name in results else None
            if name in done or proto is None:
                continue  # a file of an include folder: protoc reads it there
            done.add(name)
            known.file.append(proto)
            pending.extend(proto.dependency)
        target = scratch / path
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text, encoding="utf-8")
        try:
            compiled = compile_files(scratch, [path], self.includes, known, locations=False)
        except ProtocError:
            return _FAILED
        finally:
            target.unlink()
        proto = next(file for file in compiled.file if file.name == path)
        return _Result(proto, frozenset(keys([proto])), _defines(proto, deps, results))


def _defines(
    proto: _FileProto, deps: list[tuple[str, str]], results: dict[str, _Result]
) -> _Definitions:
    """What compiling an importer of ``proto`` can depend on: the symbols of ``proto`` and of
    everything it imports (protoc loads them all into one pool): packages, syntax, which imports
    are public, message and enum names, enum values and their numbers, extensions with their
    types, services."""
    names: set[tuple[object, ...]] = {
        ("file", proto.name, proto.package, proto.syntax, proto.edition),
        ("imports", proto.name, tuple(proto.dependency), tuple(proto.public_dependency)),
    }
    extended = list(extensions(proto, nested=False))
    for declared in declarations(proto):
        element, name = declared.proto, declared.name
        if isinstance(element, descriptor_pb2.DescriptorProto):
            names.add((name, "message"))
            extended += declared.extensions()
        else:
            names.add((name, "enum", tuple((v.name, v.number) for v in element.value)))
    names.update(
        (e.name, "extension", e.proto.extendee, e.proto.number, e.proto.type, e.proto.type_name)
        for e in extended
    )
    names.update((service.name, "service") for service in services(proto))
    for _, target in deps:
        found = results.get(target)
        if found is not None and found.defines is not None:
            names |= found.defines
    return frozenset(names)


def _ordered(targets: dict[str, list[tuple[str, str]]]) -> list[str]:
    """The files each after those it imports. A file on an import cycle, or importing one, is
    left out (protoc refuses both), and so fails its importers."""
    order: list[str] = []
    done: set[str] = set()
    bad: set[str] = set()
    for start in sorted(targets):
        if start in done:
            continue
        # Depth first without recursion: (file, its imports not yet visited).
        stack = [(start, iter(targets[start]))]
        while stack:
            path, pending = stack[-1]
            target = next((t for _, t in pending if t in targets and t not in done), None)
            if target is None:
                stack.pop()
                done.add(path)
                if path in bad or any(t in bad for _, t in targets[path]):
                    bad.add(path)
                else:
                    order.append(path)
                continue
            on_stack = [p for p, _ in stack]
            if target in on_stack:  # a cycle: every file from target up is on it
                bad.update(on_stack[on_stack.index(target) :])
            else:
                stack.append((target, iter(targets[target])))
    return order
