"""Fixtures shared by the test modules: the packaged codec and the repository's folders."""

import os
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

import erc_codec

# CI shares two cores with everything else (and `.ci/run` sets ERC_REQUIRE_INTEROP): no
# per-example deadline there, no complaint that drawing is slow (the oldest Python, loaded, draws
# a nested message in seconds), and print the blob that reproduces a failure.
settings.register_profile(
    "ci", deadline=None, print_blob=True, suppress_health_check=[HealthCheck.too_slow]
)
# The same, with a tenth of hypothesis's default 100 examples where a test does not set its own:
# for the suite on CI's other Pythons (.ci/matrix), whose job is the platform (the default Python
# searches in full), and for the pytest a test runs to read the outcomes of other tests.
settings.register_profile("ci-quick", settings.get_profile("ci"), max_examples=10)
if os.environ.get("ERC_HYPOTHESIS_PROFILE"):
    settings.load_profile(os.environ["ERC_HYPOTHESIS_PROFILE"])
elif os.environ.get("CI") or os.environ.get("ERC_REQUIRE_INTEROP"):
    settings.load_profile("ci")

REPO = Path(__file__).resolve().parent.parent
PROTO = REPO / "proto"
TESTS = REPO / "tests"  # the support modules and the trees the test modules read


@pytest.fixture(scope="session")
def codec() -> erc_codec.Codec:
    """The codec of the packaged rover schema."""
    return erc_codec.Codec.default()


@pytest.fixture(scope="session")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A stand-in for the fleet's tree (RoboTeamTwente/ERC-Protobufs, whose files are not ours
    to commit): the packaged tree with ``tests/fleet_tree``'s files over it, an envelope of 26
    members in the fleet's names and PBEnvelope_size 305, in a folder named as the fleet's."""
    tree = tmp_path_factory.mktemp("fleet") / "ERC-Protobufs"
    shutil.copytree(PROTO / "components", tree / "components")
    (tree / "components" / "common" / "envelope.options").unlink()  # the timeout's, not theirs
    shutil.copytree(REPO / "tests" / "fleet_tree" / "ERC-Protobufs", tree, dirs_exist_ok=True)
    return tree
