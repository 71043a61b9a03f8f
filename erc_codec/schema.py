"""The schema layer as ``erc_codec.schema``: every public name of ``erc_schema``, the package the
codec and the linter both stand on."""

from erc_schema import *  # noqa: F403
from erc_schema import __all__ as __all__
