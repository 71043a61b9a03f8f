"""The names nanopb's generator gives messages and enums, which ``mangle_names`` and
``(nanopb_fileopt).package`` change, and whether it finds a field's type under them.

nanopb names a declaration of a file in package ``pkg.sub`` ``pkg.sub.Outer.Inner`` by default,
``Outer.Inner`` under ``M_STRIP_PACKAGE``, ``Inner`` under ``M_FLATTEN``, ``ps.Outer.Inner`` under
``M_PACKAGE_INITIALS`` and ``NEW.Outer.Inner`` with ``package:"NEW"`` (mangling wins over it); its
C name is that name with underscores for dots, and ``.options`` patterns match it. A field's type
is looked up by the name the *referring* file's rules make of it, among the C names and the
canonical names (package and local name) the defining files registered: where the two files'
rules disagree (a file that strips its package referring to a type of a file that does not) the
generator finds nothing and writes a size guarded by a ``#if defined(...)`` that never holds.

The lookup differs in one place between generator versions: a file *without* a package but with
``(nanopb_fileopt).package = "NEW"`` looks every type up as ``NEW_<its full name>`` in nanopb's
master after 0.4.9.1 (1.0.0.dev1621's ``MangleNames.mangle_field_typename`` returns the name as it
is for a type outside the file's package only ``and self.canonical_base != Names()``, the file
having a package), so it finds its own types but no other file's; 0.4.x looks a type up by its
full name, and finds the types of files that mangle nothing too (``master_lookup``).
"""

from typing import Any

__all__ = ["nanopb_finds", "nanopb_name"]

_M_STRIP_PACKAGE, _M_FLATTEN, _M_PACKAGE_INITIALS = 1, 2, 3  # nanopb.proto's TypenameMangling

FileOptions = Any  # a NanoPBOptions instance (a message class built at run time)


def nanopb_name(package: str, file_options: FileOptions, full_name: str) -> str:
    """The dotted name nanopb gives ``full_name``, declared in a file of ``package`` whose
    resolved options are ``file_options``."""
    local = full_name[len(package) + 1 :] if package else full_name
    mangling = file_options.mangle_names
    if mangling == _M_STRIP_PACKAGE:
        return local
    if mangling == _M_FLATTEN:
        return local.rpartition(".")[2]
    if mangling == _M_PACKAGE_INITIALS:
        prefix = "".join(part[:1] for part in package.split("."))
    elif file_options.package:
        prefix = file_options.package
    else:
        prefix = package
    return f"{prefix}.{local}" if prefix else local


def nanopb_finds(
    referring: tuple[str, FileOptions],
    defining: tuple[str, FileOptions],
    full_name: str,
    *,
    master_lookup: bool = False,
) -> bool:
    """Whether nanopb's generator, writing a file of package and options ``referring``, finds
    the message or enum ``full_name`` declared in a file of package and options ``defining``;
    by the lookup of nanopb's master after 0.4.9.1 with ``master_lookup`` (see the module's
    docstring), else by 0.4.x's."""
    package, options = defining
    local = full_name[len(package) + 1 :] if package else full_name
    if options.mangle_names == _M_FLATTEN:
        local = local.rpartition(".")[2]
    registered = {_c_name(nanopb_name(*defining, full_name)), _c_name(f"{package}.{local}")}
    return _looked_up(*referring, full_name, master_lookup) in registered


def _looked_up(package: str, options: FileOptions, full_name: str, master_lookup: bool) -> str:
    """The C name a file of ``package`` with ``options`` looks the type ``full_name`` up by."""
    if options.mangle_names == _M_FLATTEN:
        return full_name.rpartition(".")[2]
    outside = not _c_name(full_name).startswith(_c_name(package) + "_")
    if outside and (package or not master_lookup):
        return _c_name(full_name)  # not of this file's package: as it is
    typename = f".{full_name}"
    replacement: str | None = None
    strip: str | None = None
    if options.mangle_names == _M_STRIP_PACKAGE:
        strip = f".{package}"
    elif options.mangle_names == _M_PACKAGE_INITIALS:
        strip = f".{package}"
        replacement = "".join(part[:1] for part in package.split("."))
    elif options.package:
        strip, replacement = f".{package}", options.package
    if strip == ".":
        strip = ""
    if strip is not None and typename.startswith(strip):
        rest = typename[len(strip) :]
        return _c_name(f"{replacement}{rest}" if replacement is not None else rest[1:])
    if options.package:
        return _c_name(f"{options.package}{typename}")
    return _c_name(full_name)


def _c_name(dotted: str) -> str:
    return "_".join(part for part in dotted.split(".") if part)
