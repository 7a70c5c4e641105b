// A VDA 5050 2.0.0 master written with coatyio's vda-5050-lib (MasterController), not with vcran's code
// (issue 31, "Must show"). It drives one vehicle on an MQTT broker through the sequence the issue names and
// prints what it observed as JSON lines on stdout, for a Python test to assert on:
//
//   1. order o1/0 from where the vehicle stands: start -> n1 released, n2 horizon (VDA 5050 §6.6.2), legs
//      of --leg metres along +x; the vehicle stops on n1, the end of its base;
//   2. startPause there (§6.8.1): what follows happens while the vehicle must not move;
//   3. order update o1/1, stitching at n1 (seq 2): n1 -> n2 -> n3 all released;
//   4. the stale update o1/0 again: to be rejected with orderUpdateError (§6.6.4.3);
//   5. stopPause a second later, and o1/1 driven to its end (n3);
//   6. order o2/0 from n3 over m1 (3 legs on) to m2, all released, and cancelOrder once it drives (§6.6.3).
//
// Each step waits for the vehicle's answer (a state message) before the next, up to STEP_TIMEOUT_S wall
// seconds; a step that times out prints {"event": "timeout"} and the script exits 1. The script judges
// nothing else: the test asserts on the lines.
//
// Usage: node master.js --broker mqtt://127.0.0.1:1883 --manufacturer M --serial S
//                       [--interface uagv] [--leg 2.0] [--virtual-agv] [--map local]
// --virtual-agv starts vda-5050-lib's own virtual AGV (AgvController + VirtualAgvAdapter, 1 m/s) in this
// process first, on the same broker, as the vehicle to drive: the script proven against the library's vehicle.
"use strict";

const { AgvController, BlockingType, MasterController, Topic, VirtualAgvAdapter } = require("vda-5050-lib");

const STEP_TIMEOUT_S = Number(process.env.STEP_TIMEOUT_S || 60);

function options(argv) {
    const o = { interface: "uagv", leg: 2.0, map: "local", virtualAgv: false };
    for (let i = 2; i < argv.length; i++) {
        const key = argv[i].replace(/^--/, "");
        if (key === "virtual-agv") { o.virtualAgv = true; continue; }
        o[key] = argv[++i];
    }
    for (const required of ["broker", "manufacturer", "serial"]) {
        if (!o[required]) { throw new Error(`master.js: --${required} is required`); }
    }
    o.leg = Number(o.leg);
    return o;
}

function emit(event, fields) {
    process.stdout.write(JSON.stringify({ event, ...fields }) + "\n");
}

// What the test needs of a state, compactly; the raw state goes out too, for the test's schema check.
function summary(state) {
    return {
        orderId: state.orderId, orderUpdateId: state.orderUpdateId,
        lastNodeId: state.lastNodeId, lastNodeSequenceId: state.lastNodeSequenceId,
        nodes: state.nodeStates.map(n => `${n.nodeId}/${n.sequenceId}${n.released ? "" : "?"}`),
        edges: state.edgeStates.map(e => `${e.edgeId}/${e.sequenceId}${e.released ? "" : "?"}`),
        driving: state.driving, paused: state.paused,
        position: state.agvPosition ? [state.agvPosition.x, state.agvPosition.y] : null,
        actions: Object.fromEntries(state.actionStates.map(a => [a.actionId, a.actionStatus])),
        errors: state.errors.map(e => ({
            type: e.errorType, level: e.errorLevel,
            refs: Object.fromEntries((e.errorReferences || []).map(r => [r.referenceKey, r.referenceValue])),
        })),
    };
}

// vda-5050-lib drops an inbound message that fails its own schema check with a console.error line: make
// it a line the test sees (a vehicle's state the library refuses is a failure of the vehicle's).
const consoleError = console.error;
console.error = (format, ...args) => {
    if (typeof format === "string" && format.startsWith("Drop inbound message")) {
        emit("dropped", { topic: args[0], reason: String(args[1]) });
    } else {
        consoleError(format, ...args);
    }
};

class Run {
    constructor(o) {
        this.o = o;
        this.agv = { manufacturer: o.manufacturer, serialNumber: o.serial };
        this.client = { interfaceName: o.interface, transport: { brokerUrl: o.broker }, vdaVersion: "2.0.0" };
        this.master = new MasterController(this.client, { targetAgvs: this.agv });
        this.states = [];
        this.waiters = [];
    }

    onState(state) {
        this.states.push(state);
        emit("state", { ...summary(state), raw: state });
        this.waiters = this.waiters.filter(w => !w.test(state) || (w.resolve(state), false));
    }

    // The first state, from now on or the latest one already received, that passes `test`.
    until(step, test, { fromLatest = true } = {}) {
        const latest = this.states[this.states.length - 1];
        if (fromLatest && latest && test(latest)) { return Promise.resolve(latest); }
        return new Promise((resolve, reject) => {
            const timer = setTimeout(() => reject(new Error(`step ${step}: no such state within ${STEP_TIMEOUT_S} s`)),
                                     STEP_TIMEOUT_S * 1000);
            this.waiters.push({ test, resolve: s => { clearTimeout(timer); resolve(s); } });
        });
    }

    handlers(name) {
        return {
            onOrderProcessed: (error, byCancelation, active, ctx) => emit("orderProcessed", {
                order: name, error: error ? { type: error.errorType, level: error.errorLevel } : null, byCancelation, active,
                lastNodeId: ctx.state.lastNodeId,
            }),
            onNodeTraversed: node => emit("nodeTraversed", { order: name, nodeId: node.nodeId, sequenceId: node.sequenceId }),
            onEdgeTraversed: edge => emit("edgeTraversed", { order: name, edgeId: edge.edgeId, sequenceId: edge.sequenceId }),
            onActionStateChanged: (actionState, error, action) => emit("orderActionState", {
                order: name, actionId: action.actionId, status: actionState.actionStatus,
            }),
        };
    }

    async assign(orderId, orderUpdateId, nodes, released) {
        const name = `${orderId}/${orderUpdateId}`;
        const order = {
            orderId, orderUpdateId,
            nodes: nodes.map(([nodeId, sequenceId, x, y], i) => ({
                nodeId, sequenceId, released: i < released, actions: [],
                nodePosition: { x, y, mapId: this.o.map, allowedDeviationXy: 0.1 },
            })),
            edges: nodes.slice(1).map(([nodeId, sequenceId], i) => ({
                edgeId: `${nodes[i][0]}-${nodeId}`, sequenceId: sequenceId - 1, released: i + 1 < released,
                startNodeId: nodes[i][0], endNodeId: nodeId, actions: [],
            })),
        };
        const sent = await this.master.assignOrder(this.agv, order, this.handlers(name));
        emit("sent", { topic: "order", order: name, headerId: sent ? sent.headerId : null, discardedByLibrary: !sent });
        return sent;
    }

    async instant(actionType) {
        const actionId = `${actionType}-${this.states.length}`;
        const sent = await this.master.initiateInstantActions(this.agv, {
            instantActions: [{ actionId, actionType, blockingType: BlockingType.Hard }],
        }, {
            onActionStateChanged: (actionState, error, action) => emit("instantActionState", {
                actionId: action.actionId, actionType, status: actionState.actionStatus,
            }),
            onActionError: (error, action) => emit("instantActionError", {
                actionId: action.actionId, actionType, type: error.errorType,
            }),
        });
        emit("sent", { topic: "instantActions", actionId, actionType, headerId: sent.headerId });
        return actionId;
    }

    async main() {
        let vehicle = null;
        if (this.o.virtualAgv) {
            vehicle = new AgvController(this.agv, this.client, { agvAdapterType: VirtualAgvAdapter },
                                        { vehicleSpeed: 1, initialPosition: { mapId: this.o.map, x: 0, y: 0, theta: 0, lastNodeId: "home" } });
            await vehicle.start();
        }
        await this.master.start();
        await this.master.subscribe(Topic.State, this.agv, state => this.onState(state));
        try {
            await this.sequence();
            emit("done", {});
        } finally {
            await this.master.stop();
            if (vehicle) { await vehicle.stop(); }
        }
    }

    async sequence() {
        const L = this.o.leg;
        // A vehicle publishes its state on events and at least every 30 s (§6.10): ask for one now (§6.8.1).
        const first = this.until("first state", s => s.agvPosition !== undefined);
        await this.instant("stateRequest");
        const { x, y } = (await first).agvPosition;
        const start = (await first).lastNodeId || "start";
        const at = k => [x + k * L, y];

        emit("step", { name: "order" });
        await this.assign("o1", 0, [[start, 0, ...at(0)], ["n1", 2, ...at(1)], ["n2", 4, ...at(2)]], 2);
        await this.until("order", s => s.orderId === "o1" && s.lastNodeId === "n1" && !s.driving);

        emit("step", { name: "pause" });
        const pause = await this.instant("startPause");
        await this.until("pause", s => s.paused && (s.actionStates.find(a => a.actionId === pause) || {}).actionStatus === "FINISHED");

        emit("step", { name: "update" });
        await this.assign("o1", 1, [["n1", 2, ...at(1)], ["n2", 4, ...at(2)], ["n3", 6, ...at(3)]], 3);
        await this.until("update", s => s.orderId === "o1" && s.orderUpdateId === 1);

        emit("step", { name: "stale" });
        await this.assign("o1", 0, [["n1", 2, ...at(1)], ["n2", 4, ...at(2)]], 2);
        await this.until("stale", s => s.errors.some(e => e.errorType === "orderUpdateError"));
        await new Promise(resolve => setTimeout(resolve, 1000));  // paused a while: the vehicle must not move

        emit("step", { name: "resume" });
        const resume = await this.instant("stopPause");
        await this.until("resume", s => !s.paused && (s.actionStates.find(a => a.actionId === resume) || {}).actionStatus === "FINISHED");
        await this.until("o1 done", s => s.lastNodeId === "n3" && s.nodeStates.length === 0 && !s.driving);

        emit("step", { name: "cancel" });
        await this.assign("o2", 0, [["n3", 0, ...at(3)], ["m1", 2, ...at(6)], ["m2", 4, ...at(7)]], 3);
        await this.until("o2 driving", s => s.orderId === "o2" && s.driving);
        const cancel = await this.instant("cancelOrder");
        await this.until("cancel", s => (s.actionStates.find(a => a.actionId === cancel) || {}).actionStatus === "FINISHED");
        await this.until("stopped", s => !s.driving);
    }
}

new Run(options(process.argv)).main().then(() => process.exit(0), error => {
    emit("timeout", { message: String(error && error.message || error) });
    process.exit(1);
});
