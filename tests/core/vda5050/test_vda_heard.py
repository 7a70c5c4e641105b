"""The orders a master hears its vehicle hold, from its states alone (vcran.core.vda5050.heard; what
``vcran manage --mqtt`` logs so that ``vcran report`` shows the vehicles' busy time, docs/vda5050.md "Live over
MQTT", docs/contract.md §11). The expectation is the vehicle's own record: the bench runs the pure vehicle, and
its ``OrderAccepted``/``OrderEnded`` effects are what a simulated run logs; the heard events, derived from
nothing but the state messages the bench published, must name the same orders ending the same way, in the
same order, each heard at the very state that showed it (no latency on the bench)."""

from __future__ import annotations

from vcran.core.vda5050.effects import OrderAccepted, OrderEnded
from vcran.core.vda5050.heard import HeardOrders
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import action, cancel, instant, order

A, B, C = ("a", 0, 0), ("b", 3, 4), ("c", 3, 8)


def test_heard_orders_are_the_vehicles_own_completed_cancelled_and_given_up():
    """o1 completes after its pick at b (HARD: the vehicle stands with work left, nodeStates empty); an
    instant startCharging the master sent then runs, RUNNING, with no order (not work: no order is heard);
    o2, sent after the charge stopped, is cancelled (§6.6.3) standing at c, a still to go; o3 is given up by an empty battery
    (docs/contract.md §4: a FATAL ``batteryEmpty`` naming the order)."""
    bench, heard = Bench(), HeardOrders()
    charge = instant(action("startCharging", "charge", "NONE"))
    stop = instant(action("stopCharging", "stop", "NONE"))
    bench.order(order("o1", 0, [A, B], node_actions={"b": [action("pick", "p1", "HARD")]}))
    bench.reach()
    bench.finish("p1")
    heard.sent("robot", charge)
    bench.instant(charge)
    bench.finish("charge")
    heard.sent("robot", stop)
    bench.instant(stop)
    bench.finish("stop")
    bench.order(order("o2", 0, [B, C, A]))
    bench.reach()  # standing at c, a still to go
    heard.sent("robot", cancel("c2"))
    bench.instant(cancel("c2"))  # standing on a node: cancelled there (Figure 9)
    bench.order(order("o3", 0, [C, A]))
    bench.call("on_halted", "battery_empty")  # on the way to a

    own = [("order_accepted", e.order_id, None) if isinstance(e, OrderAccepted) else ("order_ended", e.order_id, e.how)
           for e in bench.effects if isinstance(e, (OrderAccepted, OrderEnded))]
    assert [how for _, _, how in own if how] == ["completed", "cancelled", "battery_empty"]  # the plan above
    got = [(event, fields["order_id"], fields.get("how")) for state in bench.states
           for event, fields in heard.heard("robot", state)]
    assert got == own
