"""The HTTP server's own layer, fenced from the application: uvicorn's httptools protocol
hardened against slow and hostile clients (`protocol`), and its connection limits and counters
(`limits`). `python -m service` names the protocol; nothing else imports uvicorn's internals."""
