"""OPIL over a FIWARE Orion Context Broker (NGSI v2): the fleet's side (``vcran live``) and the fleet manager's
(``vcran manage``), on one link (docs/live.md)."""
