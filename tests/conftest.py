"""Fixtures shared by the test modules: the packaged codec and the repository's folders."""

import os
from pathlib import Path

import pytest
from hypothesis import settings

import erc_codec

# CI shares two cores with everything else (and `.ci/run` sets ERC_REQUIRE_INTEROP): no
# per-example deadline there, and print the blob that reproduces a failure.
settings.register_profile("ci", deadline=None, print_blob=True)
if os.environ.get("CI") or os.environ.get("ERC_REQUIRE_INTEROP"):
    settings.load_profile("ci")

REPO = Path(__file__).resolve().parent.parent
PROTO = REPO / "proto"


@pytest.fixture(scope="session")
def codec() -> erc_codec.Codec:
    """The codec of the packaged rover schema."""
    return erc_codec.Codec.default()
