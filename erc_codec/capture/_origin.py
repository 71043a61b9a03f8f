"""Where a schema came from, as a recording's metadata and a dissector's header say it.

The tree it was loaded from, the git commit that tree is at (``-dirty`` with uncommitted changes
in it), the root, ``<root>_size`` and a digest of the envelope's descriptors: two trees whose
envelopes read the same bytes the same way share a digest, whatever their comments or layout.
Asking git is the one thing here that runs a program; without git, or outside a work tree, the
revision is ``""``.
"""

from pathlib import Path

from erc_schema import descriptor_of

from ..codec import Codec
from ._recording import file_descriptor_set

__all__ = ["erc_codec_version", "git_revision", "schema_digest", "schema_origin"]


def schema_digest(codec: Codec) -> str:
    """``sha256:`` and the hex SHA-256 of the envelope's ``FileDescriptorSet``."""
    import hashlib  # here, as the others: nothing of this module is needed at import

    envelope = descriptor_of(codec.message_class(codec.root))
    return "sha256:" + hashlib.sha256(file_descriptor_set(envelope)).hexdigest()


def git_revision(tree: Path) -> str:
    """The commit the work tree holding ``tree`` is at, ``-dirty`` if anything under ``tree``
    is uncommitted; ``""`` outside a git work tree, before its first commit, or without git."""
    import subprocess  # here: erc-lint imports erc_codec and its start-up is measured

    # One git for both (``# branch.oid``, then a line for each change under the tree), not rev-parse
    # and status: every MCAP file starts by asking, and a git's start is some 15 ms of
    # benchmarks/bench_record.py's capture to MCAP (>= 0.7x the bare libraries, whose files carry no
    # origin); tests/capture/test_mcap.py holds the revision to rev-parse's, dirty as status.
    try:
        status = subprocess.run(
            ["git", "-C", str(tree), "status", "--porcelain=v2", "--branch", "--", "."],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    if status.returncode != 0:
        return ""
    lines = status.stdout.splitlines()
    oid = "# branch.oid "
    head = next((line[len(oid) :].strip() for line in lines if line.startswith(oid)), "")
    if not head or head == "(initial)":
        return ""
    return head + ("-dirty" if any(not line.startswith("#") for line in lines) else "")


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
