"""References for the dsp module's tests: reads a JSON list of requests per line on stdin and
prints a line {"scipy": VERSION, "answers": [...]} for each, one answer per request.

  filter    design, gain, steady, x   -> y: scipy.signal.sosfilt (or lfilter for FIR) on x
  pid_loop  pid, plant, times_ns, sp, mode, manual
            -> temp, heater: a discrete PID (the documented algorithm, written here again)
               closing the loop around a first-order-plus-dead-time vessel, as the PLC runs
               them (timeline, then plant, then dsp, each scan; points hold f32 values)
  block     kind, params, x (and t, control...) -> y: the block's documented behaviour
Each written independently of the Rust code, from docs/dsp.md.
"""

import ctypes
import ctypes.util
import json
import math
import sys
from decimal import ROUND_HALF_UP, Decimal

import numpy as np
import scipy


def f32(x):
    """What an f32 point holds."""
    with np.errstate(over="ignore"):
        return float(np.float32(x))


def round_half_away(x):
    return float(Decimal(x).to_integral_value(ROUND_HALF_UP))


def secs(ns):
    """Rust's Duration::as_secs_f64."""
    return ns // 10**9 + (ns % 10**9) / 1e9


def scalar1(v):
    return v[0] if isinstance(v, list) and len(v) == 1 else v


# ---- filters -------------------------------------------------------------------------------

def design(d):
    from scipy import signal  # only here: importing scipy.signal takes a second or two
    if "iirdesign" in d:
        r = d["iirdesign"]
        return "sos", signal.iirdesign(scalar1(r["wp"]), scalar1(r["ws"]), r["gpass"], r["gstop"],
                                       ftype=r["ftype"], output="sos", fs=r["fs"])
    if "iirfilter" in d:
        r = d["iirfilter"]
        return "sos", signal.iirfilter(r["n"], scalar1(r["wn"]), rp=r.get("rp"), rs=r.get("rs"),
                                       btype=r["btype"], ftype=r["ftype"], output="sos",
                                       fs=r["fs"])
    if "sos" in d:
        return "sos", np.array(d["sos"], dtype=float)
    if "firwin" in d:
        r = d["firwin"]
        w = r["window"]
        return "fir", signal.firwin(r["numtaps"], scalar1(r["cutoff"]),
                                    window=tuple(w) if isinstance(w, list) else w,
                                    pass_zero=r["pass_zero"], fs=r["fs"])
    if "fir" in d:
        return "fir", np.array(d["fir"], dtype=float)
    raise ValueError(f"unknown design {d}")


def run_filter(r):
    from scipy import signal
    kind, coeffs = design(r["design"])
    x = np.array(r["x"], dtype=float)
    if kind == "fir":
        return {"y": signal.lfilter(coeffs * r["gain"], [1.0], x).tolist()}
    sos = coeffs.copy()
    sos[0, :3] *= r["gain"]
    if r.get("steady"):
        y, _ = signal.sosfilt(sos, x, zi=signal.sosfilt_zi(sos) * x[0])
    else:
        y = signal.sosfilt(sos, x)
    return {"y": y.tolist()}


# ---- PID and the vessel --------------------------------------------------------------------

class Pid:
    def __init__(self, c):
        self.c = c
        p, i, d = c["p"], c["i"], c["d"]
        if c.get("form") == "ideal":
            self.kp, self.ki, self.kd = p, (p / i if i > 0 else 0.0), p * d
        else:
            self.kp, self.ki, self.kd = p, i, d
        self.lo = c.get("min_out", -math.inf)
        self.hi = c.get("max_out", math.inf)
        self.rate = c.get("rate", math.inf)
        self.tf = c.get("d_filter", 0.0)
        self.aw = c.get("anti_windup", "clamp")
        self.tt = c.get("tt")
        self.integral = self.derivative = self.x_prev = self.u = self.v = 0.0
        self.started = False

    def limit(self, v, dt, started):
        u = min(max(v, self.lo), self.hi)
        if started and math.isfinite(self.rate) and dt > 0:
            u = min(max(u, self.u - self.rate * dt), self.u + self.rate * dt)
        return u

    def step(self, sp, pv, auto, manual, dt):
        e = sp - pv
        if not math.isfinite(e) or (not auto and not math.isfinite(manual)):
            return self.u
        p = self.kp * e
        x = -pv if self.c.get("d_on_measurement", True) else e
        first = not self.started
        if first:
            self.x_prev = x
            self.derivative = 0.0
        elif dt > 0:
            self.derivative = (self.tf / (self.tf + dt) * self.derivative
                               + self.kd / (self.tf + dt) * (x - self.x_prev))
            self.x_prev = x
        self.started = True
        if not auto:
            u = self.limit(manual, dt, not first)
            self.integral = u - p - self.derivative
            self.u = self.v = u
            return u
        if first or dt == 0:
            v = p + self.integral + self.derivative
            u = self.limit(v, dt, not first)
            self.u, self.v = u, v
            return u
        before = self.integral
        self.integral += self.ki * e * dt
        if self.aw == "backcalc":
            self.integral += dt / self.tt * (self.u - self.v)
        v = p + self.integral + self.derivative
        u = self.limit(v, dt, True)
        if self.aw == "clamp" and u != v and (self.ki * e) * (v - u) > 0:
            self.integral = before
            v = p + self.integral + self.derivative
            u = self.limit(v, dt, True)
        self.u, self.v = u, v
        return u


class Vessel:
    """tau dT/dt = ambient + K u(t - theta) - T, u held between steps; signals in
    thousandths (heater %, temp degC)."""

    def __init__(self, c):
        self.k, self.tau, self.ambient = c["gain"], c["time_constant"], c["ambient"]
        self.theta = round(c["dead_time"] * 1e9)
        self.temp = c.get("initial", self.ambient)
        self.last = None
        self.applied = []  # (from_ns, power %)

    def acting(self, t):
        at = t - self.theta
        if at < 0:
            return 0.0
        power = 0.0
        for start, u in self.applied:
            if start <= at:
                power = u
        return power

    def step(self, now, heater_point):
        raw = round_half_away(heater_point * 1000.0)
        u = min(max(raw / 1000.0, 0.0), 100.0)
        if self.last is not None and now > self.last:
            if not self.applied or self.applied[-1][1] != u:
                self.applied.append((self.last, u))
            cuts = [a + self.theta for a, _ in self.applied if self.last < a + self.theta < now]
            t = self.last
            for cut in cuts + [now]:
                steady = self.ambient + self.k * self.acting(t)
                self.temp = steady + (self.temp - steady) * math.exp(-secs(cut - t) / self.tau)
                t = cut
        self.last = now
        return f32(round_half_away(self.temp * 1000.0) / 1000.0)


def pid_loop(r):
    pid, vessel = Pid(r["pid"]), Vessel(r["plant"])
    heater, last_t = 0.0, None
    temps, heaters = [], []
    for k, now in enumerate(r["times_ns"]):
        temp = vessel.step(now, heater)
        t = secs(now)
        dt = 0.0 if last_t is None else max(t - last_t, 0.0)
        last_t = t
        auto = r["mode"][k] != 0 if r.get("mode") else True
        manual = r["manual"][k] if r.get("manual") else 0.0
        heater = f32(pid.step(r["sp"][k], temp, auto, manual, dt))
        temps.append(temp)
        heaters.append(heater)
    return {"temp": temps, "heater": heaters}


# ---- the other blocks ----------------------------------------------------------------------

def ramp(p, xs, ts):
    inf = math.inf
    up, down = p.get("pos_dxdt", inf), p.get("neg_dxdt", inf)
    acc_up, acc_down = p.get("pos_d2xdt2", inf), p.get("neg_d2xdt2", inf)

    def braking(dist, a, dt):
        # Largest speed (m + f)·a·dt whose braking covers a·dt²·(m+1)(m/2+f) <= dist.
        if math.isinf(a):
            return inf
        q = dist / (a * dt * dt)
        if not math.isfinite(q) or q > 1e12:
            return math.sqrt(2 * dist * a)
        m = max(math.floor(math.sqrt(0.25 + 2 * q) - 0.5), 0)
        while (m + 1) * (m + 2) / 2 <= q:
            m += 1
        while m > 0 and m * (m + 1) / 2 > q:
            m -= 1
        f = min(max((q - m * (m + 1) / 2) / (m + 1), 0.0), 1.0)
        return (m + f) * a * dt

    out, x, v, started, last_t = [], 0.0, 0.0, False, None
    for target, t in zip(xs, ts):
        dt = 0.0 if last_t is None else max(t - last_t, 0.0)
        last_t = t
        if not math.isfinite(target):
            pass
        elif not started:
            started, x, v = True, target, 0.0
        elif dt > 0:
            d = target - x
            if d > 0:
                wanted = min(d / dt, up, braking(d, acc_down, dt))
            elif d < 0:
                wanted = -min(-d / dt, down, braking(-d, acc_up, dt))
            else:
                wanted = 0.0
            nv = min(max(wanted, v - acc_down * dt), v + acc_up * dt)
            nv = min(max(nv, -down), up)
            nxt = x + nv * dt
            crossed = (d > 0 and nxt > target) or (d < 0 and nxt < target)
            rounding = 8 * 2.220446049250313e-16 * max(abs(target), abs(x))
            x = target if (nv == d / dt or (crossed and abs(nxt - target) <= rounding)) else nxt
            v = nv
        out.append(f32(x))
    return out


def nonlinear(p, xs):
    top, bot = p.get("cutoff_top", f32(3.4028234663852886e38)), p.get("cutoff_bot", -3.4028234663852886e38)
    db_top, db_bot, db_out = p.get("deadband_top", 0.0), p.get("deadband_bot", 0.0), p.get("deadband_out", 0.0)
    gain = p.get("gain", 1.0)
    out = []
    for x in xs:
        x = x * gain
        if math.isnan(x):
            out.append(x)
            continue
        if x > db_top:
            y = db_out + (x - db_top)
        elif x < db_bot:
            y = db_out + (x - db_bot)
        else:
            y = db_out
        out.append(f32(min(max(y, bot), top)))
    return out


def alarm(p, xs):
    h, states, out = p.get("hysteresis", 0.0), [False] * len(p["limits"]), []

    def nxt(c, x, l, on):
        if c == "gt":
            return x > l or (on and x > l - h)
        if c == "ge":
            return x >= l or (on and x >= l - h)
        if c == "lt":
            return x < l or (on and x < l + h)
        if c == "le":
            return x <= l or (on and x <= l + h)
        if c == "eq":
            return x == l or (on and abs(x - l) <= h)
        return not nxt("eq", x, l, not on)

    for x in xs:
        if p.get("absolute"):
            x = abs(x)
        states = [math.isnan(x) or nxt(c, x, l, s) for (c, l), s in zip(p["limits"], states)]
        out.append([1.0 if s else 0.0 for s in states])
    return out


def multiplexor(p, controls, inputs):
    out, y = [], p.get("initial", 0.0)
    for k, c in enumerate(controls):
        if not math.isnan(c):
            y = inputs[sum(1 for l in p["limits"] if c >= l)][k]
        out.append(f32(y))
    return out


def typeconv(p, xs):
    bits, signed = p["bits"], p["signed"]
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2 ** bits - 1)
    out = []
    for x in xs:
        if math.isnan(x):
            out.append(0.0)
        elif math.isinf(x):
            out.append(float(hi if x > 0 else lo))
        else:
            out.append(float(min(max(round_half_away(x), lo), hi)))
    return out


def block(r):
    k, p = r["kind"], r.get("params", {})
    if k == "ramp":
        return {"y": ramp(p, r["x"], r["t"])}
    if k == "nonlinear":
        return {"y": nonlinear(p, r["x"])}
    if k == "alarm":
        return {"y": alarm(p, r["x"])}
    if k == "multiplexor":
        return {"y": multiplexor(p, r["control"], r["inputs"])}
    if k == "typeconv":
        return {"y": typeconv(p, r["x"])}
    if k == "add":
        out = []
        for xs in zip(*r["inputs"]):
            s = 0.0
            for x, g in zip(xs, p["gains"]):
                s = s + x * g
            out.append(f32(s))
        return {"y": out}
    if k == "mult":
        out = []
        for xs in zip(*r["inputs"]):
            s = 1.0
            for x, o in zip(xs, p["offsets"]):
                s = s * (x + o)
            out.append(f32(s))
        return {"y": out}
    if k == "pow":
        # C99's pow (Annex F: pow(-inf, 0.5) = inf, pow(0, -1) = inf, pow(-8, 1/3) = NaN), which
        # numpy.power and math.pow each depart from in places.
        libm = ctypes.CDLL(ctypes.util.find_library("m"))
        libm.pow.restype = ctypes.c_double
        libm.pow.argtypes = [ctypes.c_double, ctypes.c_double]
        return {"y": [f32(libm.pow(x, p["exponent"])) for x in r["x"]]}
    raise ValueError(f"unknown block {k}")


def finite_or_none(v):
    """JSON has no NaN or infinities: they travel as strings."""
    if isinstance(v, list):
        return [finite_or_none(x) for x in v]
    if isinstance(v, dict):
        return {k: finite_or_none(x) for k, x in v.items()}
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if v != v else ("inf" if v > 0 else "-inf")
    return v


def decode(v):
    if isinstance(v, list):
        return [decode(x) for x in v]
    if isinstance(v, dict):
        return {k: decode(x) for k, x in v.items()}
    if v in ("nan", "inf", "-inf"):
        return float(v)
    return v


def main():
    # One JSON list of requests per line, one line of answers each, until stdin closes.
    for line in sys.stdin:
        out = []
        for r in decode(json.loads(line)):
            op = r["op"]
            if op == "filter":
                out.append(run_filter(r))
            elif op == "pid_loop":
                out.append(pid_loop(r))
            elif op == "block":
                out.append(block(r))
            else:
                raise ValueError(f"unknown op {op}")
        json.dump(finite_or_none({"scipy": scipy.__version__, "answers": out}), sys.stdout)
        sys.stdout.write("\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
