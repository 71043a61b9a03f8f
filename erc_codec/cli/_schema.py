"""``erc-codec schema``: which schema the commands use, and where that was said."""

import json

import click

from erc_schema import CodecError, TreeSource, load_schema

from ..codec import Codec
from ..codec._discovery import DEFAULT_OPTIONS_FILE, ENVIRONMENT, load_source
from ._shared import Fatal, one_line, schema_options, source, text_or_json

__all__ = ["schema"]

_ORIGINS = {
    "--proto": "given with --proto",
    ENVIRONMENT: f"from the environment variable {ENVIRONMENT}",
    "packaged": "the schema packaged with erc-codec (no --proto, no "
    f"{ENVIRONMENT}, no [tool.erc-codec] in a pyproject.toml from here up)",
}


@click.command()
@schema_options
@text_or_json
def schema(tree: str | None, root: str | None, output: str) -> None:
    """Print which schema the commands use and where that was said.

    The first of these wins: --proto TREE; the environment variable
    ERC_CODEC_PROTO; [tool.erc-codec] proto = "TREE" (with root = "NAME" and
    include = ["FOLDER", ...]) in the nearest pyproject.toml from the working
    folder up, its paths relative to that file, with nanopb's options_file = "FILE",
    settings = ["OPTION=VALUE", ...] and nanopb_version = "VERSION"; the packaged
    rover schema. -I, -f, -s and --nanopb-version replace the configuration's
    include, options_file, settings and nanopb_version.
    Codec.default() finds its schema the same way. TREE is a folder (the
    import root) or a git revision GITDIR#ref=REF[,subdir=PATH].

    \b
    Exit status: 0 printed; 2 a schema that does not load (one line).
    """
    found = source(tree, root)

    def loaded(opened: TreeSource) -> tuple[str | None, Codec]:
        schema = load_schema(opened.folder, found.root, found.include, opened.shown)
        codec = Codec.from_schema(schema, found.options_file, found.settings, found.nanopb_version)
        return opened.revision, codec

    try:
        commit, codec = load_source(found, loaded)
    except CodecError as error:
        raise Fatal(one_line(str(error))) from None
    size = codec.max_size(codec.root)
    if output == "json":
        document = {
            "tree": found.tree,
            "origin": found.origin,
            "revision": commit,
            "root": codec.root,
            "include": list(found.include),
            "options_file": found.options_file,
            "settings": list(found.settings),
            "nanopb_version": found.nanopb_version,
            "members": len(codec.kinds()),
            "max_size": size,
        }
        click.echo(json.dumps(document, indent=2))
        return
    origin = _ORIGINS.get(found.origin, f"from [tool.erc-codec] in {found.origin}")
    click.echo(f"schema   {found.tree}" + (f" at commit {commit}" if commit else ""))
    click.echo(f"found    {origin}")
    click.echo(f"root     {codec.root}: {len(codec.kinds())} members, {codec.root}_size {size}")
    if found.include:
        click.echo(f"include  {', '.join(found.include)}")
    if found.options_file != DEFAULT_OPTIONS_FILE:
        click.echo(f"options  {found.options_file}")
    if found.settings:
        click.echo(f"settings {' '.join(found.settings)}")
    click.echo(f"nanopb   {found.nanopb_version} sizing rules")
