"""Python asyncua (a third-party OPC UA client) against petriplc's opcua_server.

    asyncua_client.py mixer URL PLC_ID USER PASSWORD SECONDS   browse, read, subscribe, write
    asyncua_client.py secure URL PLC_ID USER PASSWORD PKI_DIR  Basic256Sha256 Sign&Encrypt
    asyncua_client.py values URL PLC_ID                        every variant into every point
    asyncua_client.py nonfinite URL PLC_ID POINT GOOD DOUBLED  NaN, Inf refused; then GOOD

Prints one JSON object on the last line of standard output; exits 1 with a message when a
check fails.
"""

import asyncio
import datetime
import json
import math
import shutil
import sys
import time
import uuid
from pathlib import Path

from asyncua import Client, ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from cryptography.x509.oid import ExtendedKeyUsageOID

# The mixer's points: name -> (owner, OPC UA type).
MIXER = {
    "B1": ("operator", ua.VariantType.Boolean),
    "N1": ("tank", ua.VariantType.Boolean),
    "N2": ("tank", ua.VariantType.Boolean),
    "N3": ("tank", ua.VariantType.Boolean),
    "L1": ("controller", ua.VariantType.Boolean),
    "L2": ("controller", ua.VariantType.Boolean),
    "L3": ("controller", ua.VariantType.Boolean),
    "V1": ("controller", ua.VariantType.Boolean),
    "V2": ("controller", ua.VariantType.Boolean),
    "V3": ("controller", ua.VariantType.Boolean),
    "A1": ("controller", ua.VariantType.Boolean),
    "M1": ("controller", ua.VariantType.Boolean),
    "setpoint": ("opcua", ua.VariantType.UInt16),
    "stop": ("opcua", ua.VariantType.Boolean),
}


def fail(message):
    print(f"FAILED: {message}", file=sys.stderr)
    sys.exit(1)


def expect(cond, message):
    if not cond:
        fail(message)


async def expect_refused(coro, code, what):
    try:
        await coro
    except ua.UaStatusCodeError as e:
        got = ua.StatusCode(e.code).name
        expect(got == code, f"{what}: expected {code}, got {got}")
        return
    fail(f"{what}: accepted, expected {code}")


class Changes:
    """Every data change notification: (receipt time, point, value, source timestamp)."""

    def __init__(self, names):
        self.names = names
        self.seen = []

    def datachange_notification(self, node, val, data):
        now = time.time()
        dv = data.monitored_item.Value
        self.seen.append((now, self.names[node.nodeid], val, dv.SourceTimestamp.timestamp()))


async def mixer(url, plc_id, user, password, seconds):
    out = {}
    # Anonymous: read-only (anonymous = read).
    async with Client(url=url, timeout=10) as client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        objects = client.nodes.objects
        folders = {(await c.read_browse_name()).Name: c for c in await objects.get_children()}
        for module in ["operator", "tank", "controller", "opcua"]:
            expect(module in folders, f"no folder {module} below Objects: {sorted(folders)}")
        nodes = {}
        for name, (owner, vtype) in MIXER.items():
            node = await objects.get_child([f"{ns}:{owner}", f"{ns}:{name}"])
            nodes[name] = node
            bname = await node.read_browse_name()
            dname = await node.read_display_name()
            expect(bname.Name == name and bname.NamespaceIndex == ns, f"browse name {bname}")
            expect(dname.Text == name, f"display name {dname}")
            dv = await node.read_data_value()
            expect(dv.Value.VariantType == vtype, f"{name}: {dv.Value.VariantType} is not {vtype}")
            expect(dv.StatusCode.is_good(), f"{name}: status {dv.StatusCode}")
            desc = (await node.read_description()).Text
            expect(desc, f"{name} has no description")
            prop = await node.get_child([f"{ns}:Owner"])
            expect(await prop.read_value() == owner, f"{name}: Owner property")
        out["read"] = len(nodes)
        # The controller's marking and every module's status.
        marking = await objects.get_child([f"{ns}:controller", f"{ns}:Marking"])
        places = {(await p.read_browse_name()).Name: await p.read_value()
                  for p in await marking.get_children()}
        expect(len(places) >= 4, f"marking: {places}")
        out["places"] = len(places)
        state = await objects.get_child([f"{ns}:controller", f"{ns}:Status", f"{ns}:State"])
        scans = await objects.get_child([f"{ns}:controller", f"{ns}:Status", f"{ns}:Scans"])
        # The status variables follow the PLC's status file (read every 100 ms): wait for
        # what is asserted rather than a fixed while, which a loaded machine may outlast.
        deadline = time.time() + 30
        while (await state.read_value(), await scans.read_value() > 0) != ("running", True):
            expect(time.time() < deadline,
                   f"controller not running: {await state.read_value()}, "
                   f"{await scans.read_value()} scans")
            await asyncio.sleep(0.02)
        # Markings are read-only for everyone, and anonymous users may not write at all.
        place = (await marking.get_children())[0]
        await expect_refused(place.write_value(ua.DataValue(ua.Variant(5, ua.VariantType.UInt64))),
                             "BadNotWritable", "writing a marking")
        await expect_refused(
            nodes["setpoint"].write_value(ua.DataValue(ua.Variant(3, ua.VariantType.UInt16))),
            "BadUserAccessDenied", "an anonymous write")

        # Subscribe at the scan period: every change of B1, N1, N2, N3.
        watched = {nodes[n].nodeid: n for n in ["B1", "N1", "N2", "N3"]}
        changes = Changes(watched)
        params = ua.CreateSubscriptionParameters(
            RequestedPublishingInterval=10, RequestedLifetimeCount=1000,
            RequestedMaxKeepAliveCount=100, MaxNotificationsPerPublish=0, Priority=0)
        sub = await client.create_subscription(params, changes)
        out["publishing_ms"] = sub.parameters.RequestedPublishingInterval
        await sub.subscribe_data_change([nodes[n] for n in watched.values()],
                                        sampling_interval=0, queuesize=100)
        started = time.time()
        # At least `seconds`, then until every point changed twice: a loaded machine (a CI
        # runner building beside the test) may run the mixer's cycle slower than planned.
        deadline = started + max(10 * seconds, 30)
        while True:
            await asyncio.sleep(0.1)
            counts = {}
            for c in changes.seen:
                if c[3] >= started - 0.001:
                    counts[c[1]] = counts.get(c[1], 0) + 1
            done = all(counts.get(n, 0) >= 2 for n in watched.values())
            if (done and time.time() - started >= seconds) or time.time() > deadline:
                break
        await sub.delete()
        seen = [c for c in changes.seen if c[3] >= started - 0.001]
        by_point = {}
        for _, name, val, _ in seen:
            by_point.setdefault(name, []).append(bool(val))
        for n in watched.values():
            expect(len(by_point.get(n, [])) >= 2, f"{n} changed fewer than twice: {by_point}")
        latency = sorted((t - src) * 1000 for t, _, _, src in seen)
        out["changes"] = {n: v for n, v in by_point.items()}
        out["latency_ms_p50"] = latency[len(latency) // 2]
        out["latency_ms_max"] = latency[-1]

    # A user may write the points the server owns, and only those.
    client = Client(url=url, timeout=10)
    client.set_user(user)
    client.set_password(password)
    async with client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        objects = client.nodes.objects
        setpoint = await objects.get_child([f"{ns}:opcua", f"{ns}:setpoint"])
        await setpoint.write_value(ua.DataValue(ua.Variant(1234, ua.VariantType.UInt16)))
        expect(await setpoint.read_value() == 1234, "read back the written set point")
        await expect_refused(
            setpoint.write_value(ua.DataValue(ua.Variant(70000, ua.VariantType.UInt32))),
            "BadOutOfRange", "a value that does not fit")
        await expect_refused(
            setpoint.write_value(ua.DataValue(ua.Variant("x", ua.VariantType.String))),
            "BadTypeMismatch", "a string")
        v1 = await objects.get_child([f"{ns}:controller", f"{ns}:V1"])
        await expect_refused(v1.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean))),
                             "BadNotWritable", "writing the controller's V1")
        b1 = await objects.get_child([f"{ns}:operator", f"{ns}:B1"])
        await expect_refused(b1.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean))),
                             "BadNotWritable", "writing the operator's B1")
        # The write reaches the other modules: `stop` is the shutdown module's point.
        stop = await objects.get_child([f"{ns}:opcua", f"{ns}:stop"])
        await stop.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean)))
    print(json.dumps(out))


async def secure(url, plc_id, user, password, pki):
    out = {}
    work = Path(pki).parent / "client"
    work.mkdir(exist_ok=True)
    key, cert = work / "client.pem", work / "client.der"
    app_uri = "urn:petriplc-test:asyncua"
    await setup_self_signed_certificate(key, cert, app_uri, "localhost",
                                        [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "asyncua test"})

    def client_for(with_user):
        c = Client(url=url, timeout=10)
        c.application_uri = app_uri
        if with_user is not None:
            c.set_user(with_user[0])
            c.set_password(with_user[1])
        return c

    async def connect(c):
        await c.set_security(SecurityPolicyBasic256Sha256, str(cert), str(key),
                             mode=ua.MessageSecurityMode.SignAndEncrypt)
        await c.connect()
        await c.disconnect()

    # Security None is not offered.
    endpoints = await Client(url=url, timeout=10).connect_and_get_server_endpoints()
    modes = sorted({(e.SecurityPolicyUri.split("#")[-1], e.SecurityMode.name) for e in endpoints})
    expect(("None", "None_") not in modes, f"security None offered: {modes}")
    out["endpoints"] = modes
    # An unknown client certificate is refused and kept in rejected/ for the operator to trust.
    try:
        await connect(client_for((user, password)))
        fail("an untrusted client certificate was accepted")
    except Exception as e:  # noqa: BLE001 - the stack reports it in several ways
        out["untrusted"] = type(e).__name__
    rejected = list((Path(pki) / "rejected").glob("*.der"))
    expect(rejected, "the refused certificate is not in pki/rejected")
    for r in rejected:
        shutil.move(str(r), str(Path(pki) / "trusted" / r.name))
    # Trusted now: without credentials, or with a wrong password, still refused.
    for who, creds in [("no credentials", None), ("a wrong password", (user, "wrong"))]:
        try:
            await connect(client_for(creds))
            fail(f"a session with {who} was accepted")
        except ua.UaStatusCodeError as e:
            out[who] = ua.StatusCode(e.code).name
    # With the password: read and write over Sign & Encrypt.
    c = client_for((user, password))
    await c.set_security(SecurityPolicyBasic256Sha256, str(cert), str(key),
                         mode=ua.MessageSecurityMode.SignAndEncrypt)
    async with c:
        ns = await c.get_namespace_index(f"urn:petriplc:{plc_id}")
        sp = await c.nodes.objects.get_child([f"{ns}:opcua", f"{ns}:setpoint"])
        await sp.write_value(ua.DataValue(ua.Variant(77, ua.VariantType.UInt16)))
        expect(await sp.read_value() == 77, "secure write read back")
        out["secure_write"] = True
    print(json.dumps(out))


# The points of the `values` check, owned by the server: name -> (kind, bits).
POINTS = {
    "b": ("u", 1), "u3": ("u", 3), "u8": ("u", 8), "u16": ("u", 16), "u32": ("u", 32),
    "i1": ("i", 1), "i8": ("i", 8), "i12": ("i", 12), "i16": ("i", 16), "i32": ("i", 32),
    "f": ("f", 32),
}
INTS = [ua.VariantType.SByte, ua.VariantType.Byte, ua.VariantType.Int16, ua.VariantType.UInt16,
        ua.VariantType.Int32, ua.VariantType.UInt32, ua.VariantType.Int64, ua.VariantType.UInt64]
INT_RANGE = {
    ua.VariantType.SByte: (-2**7, 2**7 - 1), ua.VariantType.Byte: (0, 2**8 - 1),
    ua.VariantType.Int16: (-2**15, 2**15 - 1), ua.VariantType.UInt16: (0, 2**16 - 1),
    ua.VariantType.Int32: (-2**31, 2**31 - 1), ua.VariantType.UInt32: (0, 2**32 - 1),
    ua.VariantType.Int64: (-2**63, 2**63 - 1), ua.VariantType.UInt64: (0, 2**64 - 1),
}


def f32(x):
    """x rounded to the nearest f32, or None when that is not finite."""
    import struct
    try:
        y = struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return None
    return y if math.isfinite(y) else None


def expected(variant, kind, bits):
    """What docs/opcua.md says a write of `variant` to a (kind, bits) point gives: the value
    read back, or the refusal's status name. An oracle written from the documentation, not
    from the server's code."""
    t, v = variant.VariantType, variant.Value
    if variant.is_array or t == ua.VariantType.Null:
        return "BadTypeMismatch"
    if t == ua.VariantType.Boolean:
        return (1 if v else 0) if (kind, bits) == ("u", 1) else "BadTypeMismatch"
    if t in (ua.VariantType.Float, ua.VariantType.Double):
        if kind != "f":
            return "BadTypeMismatch"
        if not math.isfinite(v):
            return "BadOutOfRange"
        y = f32(v)
        return "BadOutOfRange" if y is None else y
    if t in INTS:
        if kind == "f":
            y = f32(float(v))
            return y if y is not None and int(y) == v else "BadOutOfRange"
        lo, hi = (0, 2**bits - 1) if kind == "u" else (-2**(bits - 1), 2**(bits - 1) - 1)
        return v if lo <= v <= hi else "BadOutOfRange"
    return "BadTypeMismatch"


def variants():
    """Every kind of variant a client may write, with the values at the edges."""
    out = [ua.Variant(True, ua.VariantType.Boolean), ua.Variant(False, ua.VariantType.Boolean)]
    for t in INTS:
        lo, hi = INT_RANGE[t]
        for v in sorted({lo, hi, 0, 1, min(hi, 2), min(hi, 5), max(lo, -1), max(lo, -8),
                         min(hi, 127), min(hi, 128), min(hi, 255), min(hi, 256),
                         max(lo, -129), min(hi, 2**24), min(hi, 2**24 + 1), min(hi, 2**40)}):
            out.append(ua.Variant(v, t))
    for t in (ua.VariantType.Float, ua.VariantType.Double):
        for v in [0.0, -0.0, 1.5, -2.25, 0.1, 3.4028234663852886e38, float("nan"),
                  float("inf"), float("-inf")]:
            out.append(ua.Variant(v, t))
    for v in [1e39, -1e39, 1e308, 1e-50, 5e-324]:
        out.append(ua.Variant(v, ua.VariantType.Double))
    out += [
        ua.Variant("1", ua.VariantType.String),
        ua.Variant("x" * 1000, ua.VariantType.String),
        ua.Variant(b"\x01", ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText("1"), ua.VariantType.LocalizedText),
        ua.Variant(ua.QualifiedName("1", 0), ua.VariantType.QualifiedName),
        ua.Variant(ua.NodeId(1, 0), ua.VariantType.NodeId),
        ua.Variant(ua.StatusCode(0), ua.VariantType.StatusCode),
        ua.Variant(datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc),
                   ua.VariantType.DateTime),
        ua.Variant(uuid.UUID(int=1), ua.VariantType.Guid),
        ua.Variant(None, ua.VariantType.Null),
        ua.Variant([1, 2], ua.VariantType.Int32),
        ua.Variant([], ua.VariantType.Int32),
        ua.Variant([float("nan")], ua.VariantType.Float),
        ua.Variant([True], ua.VariantType.Boolean),
    ]
    return out


def same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return a == b and math.copysign(1, a) == math.copysign(1, b)
    return a == b


async def values(url, plc_id):
    """Writes every variant into every point the server owns: each write either gives the
    value documented (read back exactly) or is refused with the documented status, the point
    unchanged."""
    out = {"good": 0, "refused": {}}
    async with Client(url=url, timeout=10) as client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        opcua = await client.nodes.objects.get_child([f"{ns}:opcua"])
        nodes = {name: await opcua.get_child([f"{ns}:{name}"]) for name in POINTS}
        for name, (kind, bits) in POINTS.items():
            node = nodes[name]
            for variant in variants():
                before = await node.read_value()
                want = expected(variant, kind, bits)
                what = f"{variant.VariantType.name} {variant.Value!r:.40} into {name}"
                try:
                    await node.write_value(ua.DataValue(variant))
                    got = None
                except ua.UaStatusCodeError as e:
                    got = ua.StatusCode(e.code).name
                after = await node.read_value()
                if isinstance(want, str):
                    expect(got == want, f"{what}: expected {want}, got {got or 'Good'}")
                    expect(same(after, before), f"{what}: refused, yet {before!r} became {after!r}")
                    out["refused"][want] = out["refused"].get(want, 0) + 1
                else:
                    expect(got is None, f"{what}: expected {want!r}, refused with {got}")
                    if isinstance(after, bool):
                        after = int(after)
                    expect(same(after, want), f"{what}: read back {after!r}, expected {want!r}")
                    out["good"] += 1
    print(json.dumps(out))


async def nonfinite(url, plc_id, point, good, doubled):
    """Writes NaN, +-Inf and 1e39 (an f32's Inf) to `point`, each refused with BadOutOfRange,
    then `good`; waits until the iec module's output `dbl` shows `doubled`: the module scanned
    after the writes, so it ran through them."""
    out = {}
    async with Client(url=url, timeout=10) as client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        node = await client.nodes.objects.get_child([f"{ns}:opcua", f"{ns}:{point}"])
        dbl = await client.nodes.objects.get_child([f"{ns}:calc", f"{ns}:dbl"])
        bad = [ua.Variant(float("nan"), ua.VariantType.Float),
               ua.Variant(float("inf"), ua.VariantType.Float),
               ua.Variant(float("-inf"), ua.VariantType.Float),
               ua.Variant(float("nan"), ua.VariantType.Double),
               ua.Variant(float("-inf"), ua.VariantType.Double),
               ua.Variant(1e39, ua.VariantType.Double)]
        for v in bad:
            await expect_refused(node.write_value(ua.DataValue(v)), "BadOutOfRange",
                                 f"{v.VariantType.name}({v.Value})")
        out["refused"] = len(bad)
        await node.write_value(ua.DataValue(ua.Variant(good, ua.VariantType.Float)))
        deadline = time.time() + 30
        while await dbl.read_value() != doubled:
            expect(time.time() < deadline, f"dbl never became {doubled}: {await dbl.read_value()}")
            await asyncio.sleep(0.02)
        value = await node.read_value()
        expect(value == good, f"{point} reads {value}, expected {good}")
        out["dbl"] = doubled
    print(json.dumps(out))


def main():
    what = sys.argv[1]
    if what == "mixer":
        asyncio.run(mixer(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], float(sys.argv[6])))
    elif what == "secure":
        asyncio.run(secure(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6]))
    elif what == "values":
        asyncio.run(values(sys.argv[2], sys.argv[3]))
    elif what == "nonfinite":
        asyncio.run(nonfinite(sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5]),
                              float(sys.argv[6])))
    else:
        fail(f"unknown check {what}")


if __name__ == "__main__":
    main()
