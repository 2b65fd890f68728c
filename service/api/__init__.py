"""The HTTP layer: routers, schemas, dependencies and the code → status table."""
