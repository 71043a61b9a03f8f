"""Rules on the methods of services both revisions declare, one method at a time: what a client
built from one revision and a server built from the other send each other."""

from .._model import Method
from .._pairing import Change, MethodPair
from ._registry import Report, Reports, method_rule


@method_rule("RPC_REQUEST_TYPE_CHANGED", "A method takes another request message.")
def request_type_changed(pair: MethodPair, change: Change) -> Reports:
    """## What it does
    Reports a method whose request message is another message in NEW (a message renamed with
    an identical body, or moved, is the same message).

    ## Why is this bad?
    A request travels without its type's name: the server parses the client's bytes as its
    own request type, field number by field number. A client built from OLD sends requests a
    server built from NEW misreads, field by field, or rejects.

    ## Example
    Before:
    ```proto
    message DriveRequest { float speed = 1; }
    message ArmRequest { float angle = 1; }
    service Rover { rpc Drive(DriveRequest) returns (DriveRequest); }
    ```
    After:
    ```proto
    message DriveRequest { float speed = 1; }
    message ArmRequest { float angle = 1; }
    service Rover { rpc Drive(ArmRequest) returns (DriveRequest); }
    ```

    ## Use instead
    Keep the request type; a method that takes another request is a new method
    (`rpc MoveArm(ArmRequest) returns (...)`).
    """
    old, new = pair.old, pair.new
    if new is not None and not change.same_type(old.input, new.input):
        yield Report(
            new.location,
            f"{_rpc(new)} changed request type from {_quoted(old.input)} to {_quoted(new.input)}.",
        )


@method_rule("RPC_RESPONSE_TYPE_CHANGED", "A method returns another response message.")
def response_type_changed(pair: MethodPair, change: Change) -> Reports:
    """## What it does
    Reports a method whose response message is another message in NEW (a message renamed with
    an identical body, or moved, is the same message).

    ## Why is this bad?
    A client parses the server's bytes as the response type it was built with: a client built
    from OLD misreads, field by field, or rejects what a server built from NEW returns.

    ## Example
    Before:
    ```proto
    message Status { uint32 code = 1; }
    message Report { string text = 1; }
    service Rover { rpc Ping(Status) returns (Status); }
    ```
    After:
    ```proto
    message Status { uint32 code = 1; }
    message Report { string text = 1; }
    service Rover { rpc Ping(Status) returns (Report); }
    ```

    ## Use instead
    Keep the response type; a method that returns another response is a new method.
    """
    old, new = pair.old, pair.new
    if new is not None and not change.same_type(old.output, new.output):
        yield Report(
            new.location,
            f"{_rpc(new)} changed response type from {_quoted(old.output)} to "
            f"{_quoted(new.output)}.",
        )


@method_rule("RPC_STREAMING_CHANGED", "A method changed between unary and streaming.")
def streaming_changed(pair: MethodPair, change: Change) -> Reports:
    """## What it does
    Reports a method whose client side (the requests) or server side (the responses) changed
    between one message (unary) and a stream, one finding for each side.

    ## Why is this bad?
    gRPC calls a unary and a streaming method differently: a client built from OLD and a server
    built from NEW disagree on how many messages the call carries, and the call fails (a server
    expecting one request gets several, or waits for the end of a stream that never comes).

    ## Example
    Before:
    ```proto
    message Frame { bytes data = 1; }
    service Camera { rpc Watch(Frame) returns (Frame); }
    ```
    After:
    ```proto
    message Frame { bytes data = 1; }
    service Camera { rpc Watch(Frame) returns (stream Frame); }
    ```

    ## Use instead
    Keep the method as it is and add a streaming one beside it
    (`rpc WatchStream(Frame) returns (stream Frame);`).
    """
    old, new = pair.old, pair.new
    if new is None:
        return
    for side, before, after in (
        ("client", old.client_streaming, new.client_streaming),
        ("server", old.server_streaming, new.server_streaming),
    ):
        if before != after:
            yield Report(
                new.location,
                f"{_rpc(new)} changed from {side} {_streaming(before)} to {side} "
                f"{_streaming(after)}.",
            )


@method_rule(
    "RPC_IDEMPOTENCY_CHANGED",
    "A method's idempotency_level changed: clients may retry it differently.",
    severity="warning",
)
def idempotency_changed(pair: MethodPair, change: Change) -> Reports:
    """## What it does
    Reports a method whose `idempotency_level` option changed (`IDEMPOTENCY_UNKNOWN`,
    `NO_SIDE_EFFECTS`, `IDEMPOTENT`). It is a warning: no byte changes.

    ## Why is this bad?
    gRPC clients and proxies may retry an idempotent call on their own, and some send a
    `NO_SIDE_EFFECTS` call as an HTTP GET. A method that lost its idempotency may now be run
    twice by a client built from OLD (a drive command sent twice); one that gained it is sent
    in a way a server built from OLD may not accept.

    ## Example
    Before:
    ```proto
    message Cmd { float speed = 1; }
    service Rover {
      rpc Drive(Cmd) returns (Cmd) { option idempotency_level = IDEMPOTENT; }
    }
    ```
    After:
    ```proto
    message Cmd { float speed = 1; }
    service Rover {
      rpc Drive(Cmd) returns (Cmd);
    }
    ```

    ## Use instead
    Keep the level, or change it once every client and server is built from NEW.
    """
    old, new = pair.old, pair.new
    if new is not None and new.idempotency != old.idempotency:
        yield Report(
            new.location,
            f'{_rpc(new)} changed option "idempotency_level" from "{old.idempotency}" to '
            f'"{new.idempotency}".',
        )


def _rpc(method: Method) -> str:
    return f'RPC "{method.name}" on service "{method.service}"'


def _quoted(name: str) -> str:
    return f'"{name}"'


def _streaming(streaming: bool) -> str:
    return "streaming" if streaming else "unary"
