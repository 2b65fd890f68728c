"""WebSocket stream of dynamics requests: `/v1/robots/{robot_id}/stream`.

One connection serves one robot. Each message is a request object with a `quantity` member, e.g.
`{"quantity": "gravity", "q": [...]}`, and is answered, in order, by the object the HTTP
endpoint of that quantity gives (the quantities are those of `service.api.quantities`). A text
message is JSON and is answered in JSON; a binary message is the binary form
(`service.api.encoding.binary`, `quantity` in its `__metadata__`) and is answered in the binary
form. An error is answered by a problem object (JSON text) and the stream stays open; a robot
deleted while its stream is open answers the next message with a 404 `robot_not_found`
problem. An unknown robot refuses the handshake with a 404 problem+json answer (on servers
without the ASGI denial-response extension: the problem object as the first message, then close
code 4404).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import orjson
from fastapi.exceptions import RequestValidationError
from starlette.routing import WebSocketRoute
from starlette.websockets import WebSocket

from service.api.deps import check_api_key_for_all, served_robot
from service.api.encoding import binary
from service.api.encoding.answers import json_bytes
from service.api.problems.handlers import error_response, problem_body, validation_details
from service.api.routes.dynamics import ENDPOINTS, INLINE_BODY_BYTES, PREFIX, Endpoint, off_loop
from service.errors import InvalidInput, RobodynError

log = logging.getLogger("robodyn.api")

CLOSE_ROBOT_NOT_FOUND = 4404


def _endpoint(quantity: Any) -> Endpoint:
    endpoint = ENDPOINTS.get(quantity) if isinstance(quantity, str) else None
    if endpoint is None:
        raise InvalidInput(
            f"quantity must be one of {', '.join(ENDPOINTS)}; got {str(quantity)[:40]!r}"
        )
    return endpoint


def _parse_text(text: str) -> tuple[Endpoint, dict[str, Any], dict[str, Any]]:
    """(endpoint, joint-space arrays, options) of a JSON text message."""
    try:
        body = orjson.loads(text)
    except orjson.JSONDecodeError:
        raise InvalidInput("the message is not valid JSON") from None
    if not isinstance(body, dict):
        raise InvalidInput("the message must be a JSON object with a 'quantity' member")
    endpoint = _endpoint(body.pop("quantity", None))
    arrays, options = endpoint.parse_object(body)
    endpoint.refuse_repeated_names(text, arrays, options)
    return endpoint, arrays, options


async def _answer(websocket: WebSocket, robot: Any, message: Mapping[str, Any]) -> None:
    """Answer one message. As on the HTTP routes, a large message is parsed, and a large
    batch computed and encoded, in a worker thread: the event loop serves everyone."""
    data = message.get("bytes")
    if data is not None:
        fields, arrays = binary.decode(data)
        endpoint = _endpoint(fields.pop("quantity", None))
        arrays, options = endpoint.parse_binary(fields, arrays)
        result = await endpoint.compute(websocket, robot, arrays, options, as_binary=True)
        large = websocket.scope["robodyn"]["large"]
        await websocket.send_bytes(
            await off_loop(websocket, binary.encode, result) if large else binary.encode(result)
        )
        return
    text = message.get("text") or ""
    if len(text) > INLINE_BODY_BYTES:
        endpoint, arrays, options = await off_loop(websocket, _parse_text, text)
    else:
        endpoint, arrays, options = _parse_text(text)
    result = await endpoint.compute(websocket, robot, arrays, options)
    large = websocket.scope["robodyn"]["large"]
    answer = await off_loop(websocket, json_bytes, result) if large else json_bytes(result)
    await websocket.send_text(answer.decode())


async def stream(websocket: WebSocket) -> None:
    try:
        check_api_key_for_all(websocket)
        robot = await served_robot(websocket.app.state.registry, websocket.path_params["robot_id"])
    except RobodynError as exc:
        if "websocket.http.response" in websocket.scope.get("extensions", {}):
            # Refuse the handshake with the same 404 problem+json as the HTTP routes.
            await websocket.send_denial_response(error_response(exc))  # 404 or 401
            return
        await websocket.accept()  # servers without the denial extension: problem, then close
        await websocket.send_text(
            orjson.dumps(problem_body(exc.code, exc.title, exc.detail)).decode()
        )
        await websocket.close(CLOSE_ROBOT_NOT_FOUND)
        return
    await websocket.accept()
    activity = websocket.app.state.activity
    while True:
        message = await websocket.receive()
        if message["type"] == "websocket.disconnect":
            return
        try:
            # Each message computes with the robot as it is now: one deleted under the stream
            # is a 404 robot_not_found (a stat of its record; catalog robots stay).
            robot = websocket.app.state.registry.get(robot.id)
            websocket.scope.pop("robodyn", None)  # (the previous message's)
            activity.started()
            try:
                await _answer(websocket, robot, message)
            finally:
                activity.ended(websocket.scope.get("robodyn", {}).get("large", False))
        except RobodynError as exc:
            problem = problem_body(exc.code, exc.title, exc.detail, **exc.extra)
        except RequestValidationError as exc:
            problem = problem_body("validation_error", "Invalid request", **validation_details(exc))
        except Exception:
            log.exception("unexpected error on the stream of %s", robot.id)
            problem = problem_body(
                "internal_error",
                "Internal error",
                "the service failed to answer this message; the failure was logged",
            )
        else:
            continue
        await websocket.send_text(orjson.dumps(problem).decode())


def routes() -> list[WebSocketRoute]:
    return [WebSocketRoute(f"{PREFIX}/{{robot_id}}/stream", stream, name="stream")]
