"""Where a schema came from, as a recording's metadata and a dissector's header say it.

The tree it was loaded from, the git commit that tree is at (``-dirty`` with uncommitted changes
in it), the root, ``<root>_size`` and a digest of the envelope's descriptors: two trees whose
envelopes read the same bytes the same way share a digest, whatever their comments or layout.
Asking git is the one thing here that runs a program; without git, or outside a work tree, the
revision is ``""``.
"""

from pathlib import Path

from ._codec import Codec
from ._recording import file_descriptor_set
from .schema import descriptor_of

__all__ = ["erc_codec_version", "git_revision", "schema_digest", "schema_origin"]


def schema_digest(codec: Codec) -> str:
    """``sha256:`` and the hex SHA-256 of the envelope's ``FileDescriptorSet``."""
    import hashlib  # here, as the others: nothing of this module is needed at import

    envelope = descriptor_of(codec.message_class(codec.root))
    return "sha256:" + hashlib.sha256(file_descriptor_set(envelope)).hexdigest()


def git_revision(tree: Path) -> str:
    """The commit the work tree holding ``tree`` is at, ``-dirty`` if anything under ``tree``
    is uncommitted; ``""`` outside a git work tree or without git."""
    import subprocess  # here: erc-lint imports erc_codec and its start-up is measured

    try:
        head = subprocess.run(
            ["git", "-C", str(tree), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
        if head.returncode != 0:
            return ""
        status = subprocess.run(
            ["git", "-C", str(tree), "status", "--porcelain", "--", "."],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    return head.stdout.strip() + ("-dirty" if status.stdout.strip() else "")


def erc_codec_version() -> str:
    """The installed erc-codec's version (``"unknown"`` when it runs from a bare checkout)."""
    from importlib import metadata  # here: 20 ms to import, and erc-lint's start-up is measured

    try:
        return metadata.version("erc-codec")
    except metadata.PackageNotFoundError:
        return "unknown"


def schema_origin(codec: Codec) -> dict[str, str]:
    """The schema's origin as string pairs (MCAP metadata holds strings only)."""
    tree = codec.schema.tree
    return {
        "erc_codec_version": erc_codec_version(),
        "schema_tree": str(tree),
        "schema_revision": git_revision(tree),
        "schema_root": codec.root,
        "schema_digest": schema_digest(codec),
        f"{codec.root}_size": str(codec.max_size(codec.root)),
    }
