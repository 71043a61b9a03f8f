"""What both command lines are made of: ``OneLineGroup``, the click group of ``erc-codec`` and
``erc-lint`` (every error one line, exit statuses as documented), and ``generator_options``, the
nanopb generator inputs both take (``-I``, ``-f``, ``-s``)."""

from ._generator import generator_options
from ._group import OneLineGroup

__all__ = ["OneLineGroup", "generator_options"]
