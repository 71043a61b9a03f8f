"""erc_lint's model of a revision: what nanopb sizes a root from, and its size."""

from pathlib import Path

import pytest
from lint_support import READING, tree

import erc_lint
from erc_lint._loader import load_tree
from erc_lint._model import build


@pytest.mark.parametrize(
    ("edit", "same"),
    [
        (("reading.options", "16", "32"), False),
        (("reading.proto", "MODE_RUN = 1;", "MODE_RUN = 1; MODE_BACK = -1;"), False),
        (("reading.proto", " [(nanopb).int_size = IS_8]", ""), False),
        (("reading.proto", "uint32 count", "int32 count"), False),
        (("envelope.proto", "Reading reading = 1;", "Reading reading = 1; Mode m = 2;"), False),
        (("reading.proto", "MODE_IDLE = 0;", "MODE_IDLE = 0; // idle\n"), True),
        (("reading.proto", "  Mode mode = 2;\n", "\n\n  Mode   mode = 2;  // moved\n"), True),
    ],
)
def test_equal_size_inputs_mean_equal_sizes(
    tmp_path: Path, edit: tuple[str, str, str], same: bool
) -> None:
    """ENVELOPE_SIZE_GROWN compares what nanopb sizes the root from before it computes sizes
    (bench_lint's 30-file ratio): that shortcut must agree with comparing the sizes."""
    name, before, after = edit
    changed = {**READING, name: READING[name].replace(before, after)}
    revisions = []
    for side, files in (("old", READING), ("new", changed)):
        root = tree(tmp_path / side, files)
        (root / "reading.options").write_text(files["reading.options"])
        revisions.append(build(load_tree(root)))
    old, new = revisions
    assert (old.size_inputs("PBEnvelope") == new.size_inputs("PBEnvelope")) == same
    sizes = (old.max_size("PBEnvelope"), new.max_size("PBEnvelope"))
    assert None not in sizes
    if same:
        assert sizes[0] == sizes[1]


def test_a_root_at_the_end_of_a_long_import_chain_is_sized(tmp_path: Path) -> None:
    """The files a root's size is computed from are gathered without recursion: a chain of
    imports longer than Python's recursion limit was an internal error (exit 2)."""
    chain = 1100  # files, each importing the one before
    files = {
        f"c{i}.proto": (f'import "c{i - 1}.proto";\n' if i else "") + f"message C{i} {{}}\n"
        for i in range(chain)
    }
    envelope = (
        f'import "c{chain - 1}.proto";\nmessage PBEnvelope {{ oneof p {{ C{chain - 1} c = 1; }}'
    )
    old = tree(tmp_path / "old", {**files, "env.proto": envelope + " }\n"})
    new = tree(tmp_path / "new", {**files, "env.proto": envelope + " int32 y = 2; }\n"})
    assert [f.message.split(":")[0] for f in erc_lint.lint(old, new)] == [
        'Maximum size of message "PBEnvelope" grew from 2 to 13 bytes'
    ]
