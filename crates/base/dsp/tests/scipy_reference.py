"""SciPy's answers for the DSP tests: reads a JSON list of requests per line on stdin and
prints a line of JSON answers for each, one per request, in the same order. Needs scipy (pinned by
scripts/test-all.sh into target/py).

Requests ("op" and its arguments, frequencies in Hz with "fs"):
  iirdesign  wp ws gpass gstop ftype fs        -> sos, order (from the matching *ord)
  iirfilter  n wn rp rs btype ftype fs         -> sos
  firwin     numtaps cutoff window pass_zero fs -> taps
  sosfilt    sos x                             -> y
  lfilter    b x                               -> y (FIR: a = 1)
  response   sos freqs fs                      -> gain_db at each frequency
  bessel_order wp ws gpass gstop fs            -> order, wn: the lowest order whose -3 dB
             normalised prototype, placed to meet gpass at the passband edge, meets gstop
             (an independent search with besselap, freqs_zpk and brentq)
"""

import json
import sys

import numpy as np
import scipy
from scipy import signal

ORD = {
    "butter": signal.buttord,
    "cheby1": signal.cheb1ord,
    "cheby2": signal.cheb2ord,
    "ellip": signal.ellipord,
}


def scalar1(v):
    """A one-element list as a number: SciPy takes one frequency as a scalar."""
    return v[0] if isinstance(v, list) and len(v) == 1 else v


def window(w):
    return tuple(w) if isinstance(w, list) else w


def answer(r):
    op = r["op"]
    if op == "iirdesign":
        sos = signal.iirdesign(scalar1(r["wp"]), scalar1(r["ws"]), r["gpass"], r["gstop"],
                               ftype=r["ftype"], output="sos", fs=r["fs"])
        n, wn = ORD[r["ftype"]](scalar1(r["wp"]), scalar1(r["ws"]), r["gpass"], r["gstop"], fs=r["fs"])
        return {"sos": sos.tolist(), "order": int(n), "wn": np.atleast_1d(wn).tolist()}
    if op == "iirfilter":
        sos = signal.iirfilter(r["n"], scalar1(r["wn"]), rp=r.get("rp"), rs=r.get("rs"),
                               btype=r["btype"], ftype=r["ftype"], output="sos", fs=r["fs"])
        return {"sos": sos.tolist()}
    if op == "firwin":
        taps = signal.firwin(r["numtaps"], scalar1(r["cutoff"]), window=window(r["window"]),
                             pass_zero=r["pass_zero"], fs=r["fs"])
        return {"taps": taps.tolist()}
    if op == "sosfilt":
        return {"y": signal.sosfilt(np.array(r["sos"]), np.array(r["x"])).tolist()}
    if op == "lfilter":
        return {"y": signal.lfilter(np.array(r["b"]), [1.0], np.array(r["x"])).tolist()}
    if op == "response":
        _, h = signal.sosfreqz(np.array(r["sos"]), worN=np.array(r["freqs"]), fs=r["fs"])
        return {"gain_db": (20 * np.log10(np.abs(h))).tolist()}
    if op == "bessel_order":
        return bessel_order(r)
    raise ValueError(f"unknown op {op}")


def bessel_order(r):
    from scipy.optimize import brentq
    from scipy.signal import _filter_design as fd
    wp = np.atleast_1d(2 * np.asarray(r["wp"], float) / r["fs"])
    ws = np.atleast_1d(2 * np.asarray(r["ws"], float) / r["fs"])
    filter_type = 2 * (len(wp) - 1) + 1 + (1 if wp[0] >= ws[0] else 0)
    passb, stopb = np.tan(np.pi * wp / 2), np.tan(np.pi * ws / 2)
    nat, passb = fd._find_nat_freq(stopb, passb, r["gpass"], r["gstop"], filter_type,
                                   "butter", xp=np)
    for n in range(1, 33):
        z, p, k = signal.besselap(n, norm="mag")

        def att(w):
            return -20 * np.log10(abs(signal.freqs_zpk(z, p, k, [w])[1][0]))

        w_pass = brentq(lambda w: att(w) - r["gpass"], 1e-9, 1e3, xtol=1e-15, rtol=1e-15)
        if att(w_pass * nat) >= r["gstop"]:
            w0 = 1 / w_pass
            if filter_type == 1:
                wn = [w0 * passb[0]]
            elif filter_type == 2:
                wn = [passb[0] / w0]
            elif filter_type == 3:
                d = passb[1] - passb[0]
                discr = np.sqrt(d ** 2 + 4 * w0 ** 2 * passb[0] * passb[1])
                wn = sorted(abs(np.array([(d + discr) / (2 * w0), (d - discr) / (2 * w0)])))
            else:
                w = np.array([-w0, w0])
                d = passb[1] - passb[0]
                wn = sorted(abs(-w * d / 2 + np.sqrt(w ** 2 / 4 * d ** 2 + passb[0] * passb[1])))
            wn = np.arctan(np.asarray(wn)) * 2 / np.pi * r["fs"] / 2
            return {"order": n, "wn": wn.tolist()}
    return {"order": None}


def finite_or_none(v):
    """JSON has no NaN: NaN becomes null (read back as NaN)."""
    if isinstance(v, list):
        return [finite_or_none(x) for x in v]
    if isinstance(v, dict):
        return {k: finite_or_none(x) for k, x in v.items()}
    if isinstance(v, float) and v != v:
        return None
    return v


def main():
    # One JSON list of requests per line, one line of answers each, until stdin closes.
    for line in sys.stdin:
        out = []
        for r in json.loads(line):
            try:
                out.append(answer(r))
            except Exception as e:  # reported per request, so the test names the case
                out.append({"error": f"{type(e).__name__}: {e}"})
        json.dump(finite_or_none({"scipy": scipy.__version__, "answers": out}), sys.stdout)
        sys.stdout.write("\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
