"""Request and answer schemas (pydantic): common.py, then one module per topic."""
