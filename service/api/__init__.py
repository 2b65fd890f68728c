"""The HTTP layer: the quantity table (quantities.py), the request layer (inputs.py), routes,
schemas, encoding, problems, middleware and dependencies."""
