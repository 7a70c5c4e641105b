"""How a VDA 5050 order ended (docs/report.md "VDA 5050 runs"; docs/contract.md §11): one definition,
:func:`vcran.core.jobs.order_end`, read order by order by the report's and the sweep's
:class:`~vcran.core.vda5050.outcomes.OrderLog` and event by event by the loop properties'
:func:`~vcran.core.jobs.order_unsuccessful`. One vehicle's events written by hand as the VDA 5050 glue logs
them (docs/vda5050.md): an order completed, one completed while one of its actions FAILED, one cancelled,
one given up by a collision, an update refused; an instant action's failure names no order."""

from __future__ import annotations

from vcran.core.jobs import order_unsuccessful
from vcran.core.vda5050.outcomes import Ended, order_logs


def failed(order: str | None) -> dict:
    refs = [{"referenceKey": "actionId", "referenceValue": "a1"}]
    if order is not None:
        refs.insert(0, {"referenceKey": "orderId", "referenceValue": order})
    return {"errorType": "actionFailed", "errorLevel": "WARNING", "errorReferences": refs}


EVENTS = [
    {"t": 0.0, "robot": "v", "event": "order_accepted", "order_id": "o1"},
    {"t": 5.0, "robot": "v", "event": "order_ended", "order_id": "o1", "how": "completed"},
    {"t": 6.0, "robot": "v", "event": "order_accepted", "order_id": "o2"},
    {"t": 7.0, "robot": "v", "event": "error_raised", "error": failed(None)},  # an instant action's: no order
    {"t": 8.0, "robot": "v", "event": "error_raised", "error": failed("o2")},
    {"t": 9.0, "robot": "v", "event": "order_ended", "order_id": "o2", "how": "completed"},
    {"t": 10.0, "robot": "v", "event": "order_accepted", "order_id": "o3"},
    {"t": 11.0, "robot": "v", "event": "order_rejected", "order_id": "o9"},
    {"t": 12.0, "robot": "v", "event": "order_ended", "order_id": "o3", "how": "cancelled"},
    {"t": 13.0, "robot": "v", "event": "order_accepted", "order_id": "o4"},
    {"t": 14.0, "robot": "v", "event": "order_ended", "order_id": "o4", "how": "collision"},
]


def test_the_report_and_the_loop_properties_read_one_outcome_per_order() -> None:
    log = order_logs(EVENTS)["v"]
    assert log.ended == [Ended("o1", 5.0, "completed"), Ended("o2", 9.0, "action_failed"),
                         Ended("o3", 12.0, "cancelled"), Ended("o4", 14.0, "collision")]
    assert log.rejected == 1
    # the loop properties: every order but o1 ended without success (o2 at its action's failure, 8)
    unsuccessful = [(e["t"], order) for e in EVENTS if (order := order_unsuccessful(e)) is not None]
    assert unsuccessful == [(8.0, "o2"), (11.0, "o9"), (12.0, "o3"), (14.0, "o4")]
    assert {o for _, o in unsuccessful} == {e.order_id for e in log.ended if e.outcome != "completed"} | {"o9"}
