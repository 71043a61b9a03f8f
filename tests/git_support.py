"""Git repositories for the tests: histories scripted commit by commit (``Repo``)."""

import subprocess
from pathlib import Path

HEADER = 'syntax = "proto3";\n'


class Repo:
    """A git repository the test writes history into, one commit at a time."""

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self.git("init", "-q", "-b", "main")

    def git(self, *args: str) -> str:
        done = subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t.invalid", *args],
            cwd=self.root,
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()

    def commit(self, message: str, **files: str | None) -> str:
        """Write (or, for None, delete) ``proto/<name>.proto`` files and commit; the id."""
        for name, text in files.items():
            path = self.root / "proto" / f"{name}.proto"
            if text is None:
                path.unlink()
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(HEADER + text)
        self.git("add", "-A")
        self.git("commit", "-q", "--allow-empty", "-m", message)
        return self.git("rev-parse", "HEAD")

    def spec(self, ref: str) -> str:
        return f"{self.root}#ref={ref},subdir=proto"
