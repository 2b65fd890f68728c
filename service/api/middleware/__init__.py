"""Pure ASGI middleware: the dynamics fast path, observability, body limits."""
