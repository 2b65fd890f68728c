"""Robots: the catalog, uploaded models, the durable store, model building and Data pools."""

from service.registry.registry import Registry
from service.registry.robot import Robot

__all__ = ["Registry", "Robot"]
