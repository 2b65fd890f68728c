"""What `Client` and `AsyncClient` share (`BaseClient`), and their I/O (`SyncSender`,
`AsyncSender`): the only part that differs between them.

A client method builds a `Call` (`robodyn._calls`), sends it with `_send` and returns the answer
in the client's array type. `_send` sends one request, retried as `retry` says, or — when
progress is asked for and the call is large — the call's chunks one after the other, reporting
after each. Answers are read by `core.read_response`. The method classes by topic
(`robodyn._methods`) subclass `SyncSender` or `AsyncSender`; `Client` and `AsyncClient` join
them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import httpx

from robodyn import core, outputs, shared_memory, transport
from robodyn import progress as _progress
from robodyn.answer_memory import AnswerMemory
from robodyn.core import Call
from robodyn.request_options import Fill

T = TypeVar("T")
Listener = Callable[[Mapping[str, Any]], object] | None
"""Hears the lines of a server's progress stream (`progress.StreamReporter`), or None."""


class BaseClient:
    """The settings of a client (see `Client` for the arguments) and what does not depend on
    how requests are sent."""

    def __init__(
        self,
        base_url: str | None,
        *,
        api_key: str | None,
        http_client: httpx.Client | httpx.AsyncClient | None,
        headers: Mapping[str, str] | None,
        binary: bool | None,
        retry: transport.Retry | None,
        array_type: outputs.ArrayType,
        progress: _progress.Progress,
        fill: Fill | None,
    ) -> None:
        self._settings = transport.settings(base_url, api_key, http_client, headers, binary, fill)
        self._retry = retry
        self._array_type = outputs.check_array_type(array_type)
        self._progress = _progress.check(progress)
        self._owns_http = http_client is None
        unix_socket = self._settings.unix_socket
        self._answer_memory = AnswerMemory()  # large answers' memory, reused (answer_memory.py)
        self._shared = (
            None
            if unix_socket is None
            else shared_memory.SharedMemory(unix_socket, self._answer_memory)
        )

    @property
    def base_url(self) -> str:
        """The server's base URL, e.g. `http://127.0.0.1:8000` (or `unix:///path` for a
        Unix socket)."""
        return self._settings.address

    def _report(self, progress: _progress.Progress) -> _progress.Progress:
        """Where to report progress: `progress` of this call, else the client's (None)."""
        return _progress.check(progress) if progress is not None else self._progress

    def _chunks(self, call: Call[T], report: _progress.Progress) -> _progress.Chunks[T] | None:
        """The chunks to send `call` in: only when progress is asked for and there is more
        than one chunk; then the whole batch is checked finite first (`Call.check_finite`), so
        that an error names the state in the batch and comes before any chunk is sent."""
        if report is None or call.chunks is None or not call.chunks.worth_it:
            return None
        call.check_finite()
        return call.chunks

    def _answer(self, result: T) -> T:
        return outputs.convert(result, self._array_type)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.base_url!r})"


class SyncSender(BaseClient):
    """The blocking I/O of `Client`: one pooled `httpx.Client`."""

    _http: httpx.Client

    def _send(self, call: Call[T], progress: _progress.Progress = None) -> T:
        """Send `call` (in chunks with progress, or asking for the server's progress stream;
        retried as `retry` says); its answer in the client's array type."""
        report = self._report(progress)
        if report is not None and call.progress_stream:
            with _progress.StreamReporter(report) as listener:
                answer = self._fetch(call, listener)
                listener.finish()
            return self._answer(answer)
        chunks = self._chunks(call, report)
        if chunks is None:
            return self._answer(self._fetch(call))
        with _progress.Reporter(report, chunks.total, chunks.unit) as reporter:
            plan = chunks.plan()
            part, done = next(plan)
            while True:
                answer = self._fetch(part)
                reporter(done)
                try:
                    part, done = plan.send(answer)
                except StopIteration as end:
                    joined: T = end.value
                    return self._answer(joined)

    def _fetch(self, call: Call[T], listener: Listener = None) -> T:
        try:  # the first attempt outside stamina: ~30 µs less per call that succeeds
            return self._fetch_once(call, listener)
        except transport.RETRIED as exc:
            failure: Exception | None = exc
            if self._retry is None:
                raise
        for attempt in transport.retry_context(call, self._retry):
            with attempt:
                if failure is not None:  # stamina decides on the first failure, and waits
                    first, failure = failure, None
                    raise first
                return self._fetch_once(call, listener)
        raise AssertionError("unreachable: the last attempt returns or raises")

    def _fetch_once(self, call: Call[T], listener: Listener = None) -> T:
        url, headers, body = self._settings.prepare(call, listener is not None)
        segment, body = transport.shared_body(self._shared, call, headers, body)
        try:
            content: Any = body  # bytes, or parts (bytes and memoryviews) httpx sends in turn
            received: Any
            with (
                transport.wrapped(call.method, url),
                self._http.stream(call.method, url, content=content, headers=headers) as response,
            ):
                if listener is not None and core.is_progress_stream(response):
                    lines = core.ProgressLines(call, listener)
                    for line in response.iter_lines():
                        lines.feed(line)
                    return lines.result()
                length = core.binary_length(response)
                if length is None:
                    response.read()
                    received = transport.shared_answer(segment, response)
                else:  # a large binary answer: straight into one buffer
                    receiver = core.Receiver(response, length, self._answer_memory)
                    for chunk in response.iter_raw():
                        receiver.add(chunk)
                    received = receiver.finish()
            transport.refused_shared_body(call, segment, response.status_code)
            return core.read_response(call, response, received)
        finally:
            if segment is not None:  # its files removed, whatever happened
                segment.release()

    def close(self) -> None:
        """Close the connection pool (not an injected `http_client`) and remove the
        client's shared-memory files."""
        if self._shared is not None:
            self._shared.close()
        self._answer_memory.clear()
        if self._owns_http:
            self._http.close()


class AsyncSender(BaseClient):
    """The asyncio/trio I/O of `AsyncClient`: one pooled `httpx.AsyncClient`."""

    _http: httpx.AsyncClient

    async def _send(self, call: Call[T], progress: _progress.Progress = None) -> T:
        """Send `call` (in chunks with progress, or asking for the server's progress stream;
        retried as `retry` says); its answer in the client's array type."""
        report = self._report(progress)
        if report is not None and call.progress_stream:
            with _progress.StreamReporter(report) as listener:
                answer = await self._fetch(call, listener)
                listener.finish()
            return self._answer(answer)
        chunks = self._chunks(call, report)
        if chunks is None:
            return self._answer(await self._fetch(call))
        with _progress.Reporter(report, chunks.total, chunks.unit) as reporter:
            plan = chunks.plan()
            part, done = next(plan)
            while True:
                answer = await self._fetch(part)
                reporter(done)
                try:
                    part, done = plan.send(answer)
                except StopIteration as end:
                    joined: T = end.value
                    return self._answer(joined)

    async def _fetch(self, call: Call[T], listener: Listener = None) -> T:
        try:  # the first attempt outside stamina: ~30 µs less per call that succeeds
            return await self._fetch_once(call, listener)
        except transport.RETRIED as exc:
            failure: Exception | None = exc
            if self._retry is None:
                raise
        async for attempt in transport.retry_context(call, self._retry):
            with attempt:
                if failure is not None:  # stamina decides on the first failure, and waits
                    first, failure = failure, None
                    raise first
                return await self._fetch_once(call, listener)
        raise AssertionError("unreachable: the last attempt returns or raises")

    async def _fetch_once(self, call: Call[T], listener: Listener = None) -> T:
        url, headers, body = self._settings.prepare(call, listener is not None)
        segment, body = transport.shared_body(self._shared, call, headers, body)
        try:
            content: Any = transport.parts_async(body) if isinstance(body, list) else body
            received: Any
            with transport.wrapped(call.method, url):
                async with self._http.stream(
                    call.method, url, content=content, headers=headers
                ) as response:
                    if listener is not None and core.is_progress_stream(response):
                        lines = core.ProgressLines(call, listener)
                        async for line in response.aiter_lines():
                            lines.feed(line)
                        return lines.result()
                    length = core.binary_length(response)
                    if length is None:
                        await response.aread()
                        received = transport.shared_answer(segment, response)
                    else:  # a large binary answer: straight into one buffer
                        receiver = core.Receiver(response, length, self._answer_memory)
                        async for chunk in response.aiter_raw():
                            receiver.add(chunk)
                        received = receiver.finish()
            transport.refused_shared_body(call, segment, response.status_code)
            return core.read_response(call, response, received)
        finally:
            if segment is not None:  # its files removed, whatever happened
                segment.release()

    async def aclose(self) -> None:
        """Close the connection pool (not an injected `http_client`) and remove the
        client's shared-memory files."""
        if self._shared is not None:
            self._shared.close()
        self._answer_memory.clear()
        if self._owns_http:
            await self._http.aclose()
