"""What a tree, or every revision of a git history, adds to a number ledger.

Guarantees:
- ``--history`` visits every commit reachable from the ref, each after its parents, so an entry's
  revision is the first commit (in that order) whose tree carried it, on whichever branch.
- A file is compiled again only when it or a file it imports (transitively) changed: the result
  of each file is cached under the blob ids of that closure. A history of n revisions that each
  change one file costs about n compilations of one file, not n of the whole tree.
- A file that does not compile in a revision records nothing for that revision; the others do.
"""

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path

from ._git import Repository
from ._inputs import GitInput, materialize
from ._ledger import Entry, Key, Ledger
from ._loader import by_basename, imports, load_tree, matches
from ._model import Revision, build

__all__ = ["History", "keys"]


def keys(revision: Revision, files: Sequence[str] | None = None) -> set[Key]:
    """What the ledger records of a revision (of its ``files`` only, when given)."""
    wanted = None if files is None else set(files)
    found: set[Key] = set()
    for message in revision.messages.values():
        if wanted is None or message.file in wanted:
            for entry in message.fields.values():
                found.add(Key("message", message.name, entry.number, entry.name, entry.type))
    for enum in revision.enums.values():
        if wanted is None or enum.file in wanted:
            for value in enum.by_name.values():
                found.add(Key("enum", enum.name, value.number, value.name, "-"))
    return found


@dataclass
class History:
    """Walks revisions of one git input, compiling only what changed since the last one."""

    repository: Repository
    spec: GitInput
    includes: Sequence[Path] = ()
    exclude: Sequence[str] = ()
    compiled: int = 0  # files compiled so far, for the benchmark's report
    _cache: dict[tuple[tuple[str, str], ...], frozenset[Key]] = field(default_factory=dict)
    _imports: dict[str, list[str]] = field(default_factory=dict)  # blob → import spellings
    _present: dict[str, str] = field(default_factory=dict)  # what the scratch folder holds

    def update(self, ledger: Ledger, commits: Sequence[str]) -> list[Entry]:
        """Add every revision of ``commits`` (parents first) to ``ledger``; the new entries."""
        added: list[Entry] = []
        with tempfile.TemporaryDirectory(prefix="erc-lint-history-") as scratch:
            for commit in commits:
                files = self.repository.files(commit, self.spec.subdir)
                added += ledger.add(self._keys(files, Path(scratch)), commit[:12])
        return added

    def _keys(self, files: dict[str, str], scratch: Path) -> set[Key]:
        protos = {path: blob for path, blob in files.items() if path.endswith(".proto")}
        checked = [p for p in protos if not any(fnmatchcase(p, x) for x in self.exclude)]
        closures = self._closures(protos)
        missing = [path for path in checked if closures[path] not in self._cache]
        if missing:
            self._present = materialize(self.repository, protos, scratch, self._present)
            revision = build(load_tree(scratch, self.includes, self.exclude, only=missing))
            self.compiled += len(missing)
            for path in missing:
                self._cache[closures[path]] = frozenset(keys(revision, [path]))
        found: set[Key] = set()
        for path in checked:
            found |= self._cache[closures[path]]
        return found

    def _closures(self, protos: dict[str, str]) -> dict[str, tuple[tuple[str, str], ...]]:
        """Each file's cache key: the (path, blob) of itself and of all it imports, sorted."""
        index = by_basename(protos)
        direct: dict[str, list[str]] = {}
        for path, blob in protos.items():
            spellings = self._imports.get(blob)
            if spellings is None:
                text = self.repository.read(blob).decode("utf-8", "replace")
                spellings = self._imports[blob] = [s for _, _, s in imports(text)]
            targets = []
            for spelling in spellings:
                found = [spelling] if spelling in protos else matches(spelling, protos, index)
                targets += found[:1] if len(found) == 1 else [f"?{spelling}"]
            direct[path] = targets
        closures = {}
        for path in protos:
            seen, pending = {path}, [path]
            while pending:
                for target in direct.get(pending.pop(), []):
                    if target not in seen:
                        seen.add(target)
                        pending.append(target)
            closures[path] = tuple(sorted((name, protos.get(name, "")) for name in seen))
        return closures
