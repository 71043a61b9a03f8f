"""Fixtures shared by the test modules: the packaged codec and the repository's folders."""

from pathlib import Path

import pytest

import erc_codec

REPO = Path(__file__).resolve().parent.parent
PROTO = REPO / "proto"


@pytest.fixture(scope="session")
def codec() -> erc_codec.Codec:
    """The codec of the packaged rover schema."""
    return erc_codec.Codec.default()
