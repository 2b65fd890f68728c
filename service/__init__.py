"""robodyn: rigid-body dynamics of any robot over HTTP, on Pinocchio."""

__version__ = "0.1.0"
