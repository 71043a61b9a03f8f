"""erc_schema's walk over compiled files (``declarations``, ``SourceIndex``) and its reading
of a file's text before it compiles (``declared_names``), against a file written here."""

from pathlib import Path

import pytest
from google.protobuf import descriptor_pb2

from erc_schema import (
    Location,
    SourceIndex,
    compile_files,
    declarations,
    declared_names,
    extensions,
    services,
)

SOURCE = """\
syntax = "proto2";
package rover.arm;

message Outer {
  message Inner {
    message Leaf {  // the leaf
      optional int32 x = 1;
    }
    enum Mode { MODE_A = 0; }
  }
  enum Colour { RED = 0; GREEN = 1; }
  optional Inner inner = 1;
  oneof pick {
    int32 a = 2;
    int32 b = 3;  // second member
  }
  extensions 100 to 200;
  extend Outer { optional int32 nested_ext = 100; }
}

message Second {}

enum Top { TOP_ZERO = 0; }

extend Outer { optional int32 top_ext = 101; }

service Arm { rpc Move (Second) returns (Second); }
"""


@pytest.fixture(scope="module")
def proto(tmp_path_factory: pytest.TempPathFactory) -> descriptor_pb2.FileDescriptorProto:
    tree = tmp_path_factory.mktemp("descriptors")
    (tree / "arm.proto").write_text(SOURCE)
    return compile_files(tree, ["arm.proto"], defaults=False, imports=False).file[0]


def test_declarations_walk_depth_first_in_file_order(
    proto: descriptor_pb2.FileDescriptorProto,
) -> None:
    found = [(d.name, d.is_message, d.parent, d.scope) for d in declarations(proto)]
    assert found == [
        ("rover.arm.Outer", True, None, "rover.arm."),
        ("rover.arm.Outer.Inner", True, "rover.arm.Outer", "rover.arm.Outer."),
        ("rover.arm.Outer.Inner.Leaf", True, "rover.arm.Outer.Inner", "rover.arm.Outer.Inner."),
        ("rover.arm.Outer.Inner.Mode", False, "rover.arm.Outer.Inner", "rover.arm.Outer.Inner."),
        ("rover.arm.Outer.Colour", False, "rover.arm.Outer", "rover.arm.Outer."),
        ("rover.arm.Second", True, None, "rover.arm."),
        ("rover.arm.Top", False, None, "rover.arm."),
    ]


def test_declarations_reach_the_deepest_nesting_protoc_parses(tmp_path: Path) -> None:
    depth = 30  # protoc's own parser stops at 32 levels
    text = "".join(f"message M{i} {{ " for i in range(depth)) + "}" * depth
    (tmp_path / "deep.proto").write_text(f'syntax = "proto3";\n{text}\n')
    proto = compile_files(tmp_path, ["deep.proto"], locations=False).file[-1]
    names = [d.name for d in declarations(proto)]
    assert len(names) == depth
    assert names[-1] == ".".join(f"M{i}" for i in range(depth))


def test_source_index_finds_declarations_members_and_comments(
    proto: descriptor_pb2.FileDescriptorProto,
) -> None:
    index = SourceIndex("arm.proto", proto)
    by_name = {d.name: d for d in declarations(proto)}
    outer, leaf = by_name["rover.arm.Outer"], by_name["rover.arm.Outer.Inner.Leaf"]
    assert index.find(outer.path) == Location("arm.proto", 4, 1)
    assert index.find(leaf.path) == Location("arm.proto", 6, 5)
    assert index.comment(leaf.path) == "the leaf"
    assert index.find(outer.member(2)) == Location("arm.proto", 15, 5)  # field b
    assert index.comment(outer.member(2)) == "second member"
    assert index.find(outer.oneof(0)) == Location("arm.proto", 13, 3)
    assert index.find(by_name["rover.arm.Outer.Colour"].member(1)) == Location("arm.proto", 11, 26)
    assert str(index.find(outer.path)) == "arm.proto:4:1"


def test_source_index_of_a_path_protoc_did_not_record(
    proto: descriptor_pb2.FileDescriptorProto,
) -> None:
    index = SourceIndex("arm.proto", proto)
    assert index.find((4, 99)) is None
    assert index.where((4, 99)) == Location("arm.proto", 1, 1)
    assert index.comment((4, 99)) == ""


def test_source_index_without_source_info(tmp_path: Path) -> None:
    (tmp_path / "a.proto").write_text('syntax = "proto3";\nmessage A {}\n')
    proto = compile_files(tmp_path, ["a.proto"], locations=False).file[-1]
    assert SourceIndex("a.proto", proto).find((4, 0)) is None


def test_extensions_and_services_with_their_paths(
    proto: descriptor_pb2.FileDescriptorProto,
) -> None:
    index = SourceIndex("arm.proto", proto)
    found = [(e.name, e.scope, index.find(e.path)) for e in extensions(proto)]
    assert found == [
        ("rover.arm.top_ext", None, Location("arm.proto", 25, 16)),
        ("rover.arm.Outer.nested_ext", "rover.arm.Outer", Location("arm.proto", 18, 18)),
    ]
    assert [e.name for e in extensions(proto, nested=False)] == ["rover.arm.top_ext"]
    (service,) = services(proto)
    assert service.name == "rover.arm.Arm"
    assert index.find(service.method(0)) == Location("arm.proto", 27, 15)


def test_declared_names_reads_the_text_as_protoc_tokenizes_it() -> None:
    text = """
    message Outer { message Inner {} enum Mode { A = 0; } optional group Item = 1 {} }
    // message InComment {}
    /* enum InBlock {} */
    option (x) = "message InString {}";
    enum
      Split {}
    """
    assert declared_names(text) == frozenset({"Outer", "Inner", "Mode", "Item", "Split"})
    assert declared_names("") == frozenset()
