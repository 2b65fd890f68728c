"""The model check: the inertias a description claims, against physics and the link's own
geometry, and their repairs.

    geometry        unit-density mass properties: box, cylinder, sphere, capsule in closed
                    form, closed meshes by the divergence theorem, convex hulls, placed and
                    added
    link_geometry   a link's collision (else visual) elements as one body
    findings        the errors and warnings of a link, and of left/right twins
    repairs         from the geometry, or the nearest valid principal moments
    report          the route's answer, and the repairs a variant or an upload plans
"""

from service.dynamics.model_check.report import model_check, planned_repairs

__all__ = ["model_check", "planned_repairs"]
