"""A large batch may run in one native call only when the serving process has nothing else to
serve and its deadline is far (`service.api.activity`, `Cancellation.may_hold`); the app counts
every HTTP request and stream message."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
import pytest

from service.api import activity as activity_module
from service.api.activity import QUIET_S, Activity
from service.api.cancellation import MAX_HOLD_S, Cancellation
from service.errors import DeadlineExceeded


def _long_ago(activity: Activity) -> Activity:
    activity.last_small_end = time.monotonic() - 10 * QUIET_S
    return activity


def test_a_lone_request_is_quiet_once_small_requests_have_stopped():
    activity = _long_ago(Activity())
    activity.started()  # the batch's own request
    assert activity.quiet()
    activity.started()  # another request arrives
    assert not activity.quiet()
    activity.ended(large=False)  # ... and ends: still not quiet for QUIET_S
    assert activity.in_flight == 1 and not activity.quiet()


def test_large_batches_ending_leave_the_process_quiet():
    """Batches one after the other from one client (each computed off the event loop) do not
    keep the next one in short calls."""
    activity = _long_ago(Activity())
    activity.started()
    activity.ended(large=True)
    activity.started()
    assert activity.quiet()


def test_quiet_after_the_pause(monkeypatch):
    activity = Activity()
    activity.started()
    activity.ended(large=False)
    activity.started()
    assert not activity.quiet()
    later = time.monotonic() + QUIET_S + 0.01
    monkeypatch.setattr(activity_module.time, "monotonic", lambda: later)
    assert activity.quiet()


def test_may_hold_asks_activity_deadline_and_client():
    activity = _long_ago(Activity())
    activity.started()
    cancellation = Cancellation("inverse-dynamics", 0.1, activity=activity)
    assert cancellation() is False  # the computation starts: its deadline is set
    assert cancellation.may_hold(0.01)
    assert not cancellation.may_hold(0.06)  # 2 × 0.06 s would pass the 0.1 s deadline
    assert not Cancellation("x", 60.0, activity=activity).may_hold(MAX_HOLD_S * 1.5)
    activity.started()
    assert not cancellation.may_hold(0.01)  # another request is in flight
    activity.ended(large=True)
    assert cancellation.may_hold(0.01)
    cancellation.disconnected = True
    assert not cancellation.may_hold(0.01)
    assert not Cancellation("x", 60.0).may_hold(0.01)  # without activity: never


def test_a_held_batch_still_meets_its_deadline(catalog_registry):
    """With a deadline too short for the batch, the batch is never held in one call: it is
    stopped between calls with 504 deadline_exceeded's error."""
    from service.api.quantities import SPECS
    from service.dynamics import run
    from service.states import States

    robot = catalog_registry.get("talos")
    n = 40_000
    rng = np.random.default_rng(0)
    q = np.tile(pin.neutral(robot.model), (n, 1))
    v, a = rng.normal(size=(2, n, robot.nv))
    activity = _long_ago(Activity())
    activity.started()
    cancellation = Cancellation("inverse-dynamics", 1e-4, activity=activity)
    with pytest.raises(DeadlineExceeded):
        run(
            robot,
            SPECS["inverse-dynamics"].quantity,
            States({"q": q, "v": v, "a": a}, True),
            {},
            cancellation,
        )


def test_the_app_counts_requests_in_flight(api):
    """Every HTTP request is counted while answered, and none is left counted."""
    activity: Activity = api.app.state.activity
    before = activity.in_flight
    r = api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6})
    assert r.status_code == 200
    assert activity.in_flight == before
    assert time.monotonic() - activity.last_small_end < 5.0
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_json({"quantity": "gravity", "q": [0.0] * 6})
        ws.receive_json()
    assert activity.in_flight == before
