"""The fit's input ablation (bpy-free): which input groups a network fitted to one scene can do without.

``droppable`` lists the groups a head does not need, in the channel spec's ablation order
(``channels.drop_order``: `world` first, a whole second EEVEE render); ``drop_inputs`` cuts a group's
channels out of the weights that read the input and keeps every other weight (weight surgery);
``select_inputs`` runs the ablation with them (learn/fit.py, step 3).
"""
from __future__ import annotations

import torch

from .. import channels as ch
from .. import normalize
from ..errors import UserError
from ..evaluate.fit_report import number
from . import network


def _carry(net, arch: dict, columns) -> torch.nn.Module:
    """``network.build(arch)`` with ``net``'s weights: a weight of the same shape is copied; a weight that reads
    the input tensor (the first conv, and the layer where the input is concatenated again; in both backbones
    the input comes LAST in the concatenation) gets ``columns(old, new)``: the new weight from the old one."""
    new = network.build(arch)
    c_old, c_new = ch.input_channels(tuple(net.arch["inputs"])), ch.input_channels(tuple(arch["inputs"]))
    old_sd, out = net.state_dict(), {}
    for k, w in new.state_dict().items():
        o = old_sd[k]
        if o.shape == w.shape:
            out[k] = o.detach().clone()
            continue
        if o.dim() != 4 or o.shape[1] - w.shape[1] != c_old - c_new or o.shape[0] != w.shape[0] or o.shape[2:] != w.shape[2:]:
            raise UserError(f"cannot carry weight {k} {tuple(o.shape)} over to inputs "
                            f"{ch.format_spec(tuple(arch['inputs']))} {tuple(w.shape)}")
        out[k] = columns(o.detach(), w, o.shape[1] - c_old)
    new.load_state_dict(out)
    return new


def _columns_of(sub, full, why: str) -> list[int]:
    """The input channels (indices into ``full``'s layout) of the groups of ``sub``, which must be a
    sub-sequence of ``full`` (UserError ``why`` if not): the columns drop_inputs keeps and grow_inputs fills."""
    if [g for g in full if g in sub] != list(sub):
        raise UserError(why)
    lay = normalize.layout(full)
    return [i for g in sub for i in range(lay[g].start, lay[g].stop)]


def drop_inputs(net, new_spec) -> torch.nn.Module:
    """A network for ``new_spec`` (a sub-sequence of ``net``'s input spec, same order) with ``net``'s weights:
    every weight that reads the input keeps the columns of the kept channels (``_carry``)."""
    old_spec = tuple(net.arch["inputs"])
    new_spec = ch.parse_spec(new_spec)
    kept = _columns_of(new_spec, old_spec, f"inputs {ch.format_spec(new_spec)} are not a sub-sequence of "
                                           f"{ch.format_spec(old_spec)}")
    return _carry(net, dict(net.arch, inputs=list(new_spec)),
                  lambda o, w, base: o[:, list(range(base)) + [base + i for i in kept]].clone())


def grow_inputs(net, new_spec, target: str | None = None) -> torch.nn.Module:
    """The inverse of ``drop_inputs``: a network for ``new_spec`` (holding ``net``'s inputs in the same order,
    plus new groups anywhere) with ``net``'s weights, the new channels' weights 0, so that it computes exactly
    what ``net`` does until training changes them (``cli.py train --init``). ``target``: what the new network
    predicts (default: ``net``'s)."""
    old_spec = tuple(net.arch["inputs"])
    new_spec = ch.parse_spec(new_spec)
    kept = _columns_of(old_spec, new_spec, f"inputs {ch.format_spec(new_spec)} do not hold "
                                           f"{ch.format_spec(old_spec)} in that order")

    def columns(o, w, base):
        grown = torch.zeros_like(w)
        grown[:, :base] = o[:, :base]
        grown[:, [base + i for i in kept]] = o[:, base:]
        return grown

    arch = dict(net.arch, inputs=list(new_spec), target=ch.check_target(target or network.target_of(net.arch)))
    return _carry(net, arch, columns)


def droppable(spec, head: str) -> list[str]:
    need = network.HEAD_NEEDS.get(head, ())
    return [g for g in ch.drop_order() if g in spec and g not in need]


def silent_groups(spec, samples) -> list[str]:
    """The groups of ``spec`` whose network input is exactly 0 on every one of ``samples`` (``data.Sample``,
    built for ``spec``): a pass the scene never lights (no world light in a black world, no emitter). A 0 input
    adds nothing to any convolution (zero padding), so cutting its weights out (``drop_inputs``) leaves the
    network's output on these views exactly as it was."""
    lay = normalize.layout(tuple(spec))
    return [g for g in spec if samples and all(not bool(s.x[lay[g]].any()) for s in samples)]


def select_inputs(net, train, seconds: float, drop_tol: float, rows: list, log, silent=()) -> tuple:
    """Which input groups ``net`` can do without. ``train(name, arch, spec, seconds, init_state)`` -> (net with
    the best val weights, summary with ``val_psnr`` and ``minutes``) fine-tunes for ``seconds``; every run gets
    the same time. The control fine-tunes ``net`` on its own inputs; each droppable group is tried alone (its
    input weights cut out of ``net`` by ``drop_inputs``); a group can go when the val PSNR without it is at most
    ``drop_tol`` dB below the control's. Every trial starts from ``net``, so the comparison is fair; when
    several can go, their union is checked together (one more run), and when that costs more than
    ``drop_tol`` only the cheapest goes. One row per decision is appended to ``rows``. ``silent``: droppable
    groups that are 0 on every view (``silent_groups``): they go first, without a run (exact).
    Returns (net, spec, control val PSNR; None when nothing is droppable)."""
    spec = tuple(net.arch["inputs"])
    head = net.arch.get("head", "log")
    groups = droppable(spec, head)
    for g in spec:
        if g not in groups:
            rows.append(dict(phase="inputs", group=g, spec=None, decision=f"kept (the {head} head needs it)"))
    gone = [g for g in groups if g in set(silent)]
    if gone:
        spec = tuple(x for x in spec if x not in gone)
        net = drop_inputs(net, spec)
        groups = [g for g in groups if g not in gone]
        for g in gone:
            rows.append(dict(phase="inputs", group=g, spec=ch.format_spec(spec), passes=list(ch.required_passes(spec)),
                             decision="dropped (0 on every view: no run needed)"))
        log(f"inputs: {', '.join(gone)} 0 on every view -> dropped without a run")
    if not groups:
        rows.append(dict(phase="inputs", group="(all)", decision="nothing else to drop" if gone else "nothing to drop"))
        return net, spec, None

    def row(group, sp, r, delta, decision):
        rows.append(dict(phase="inputs", group=group, spec=ch.format_spec(sp), passes=list(ch.required_passes(sp)),
                         val_psnr=r["val_psnr"], delta_db=number(delta), seconds=number(60 * r["minutes"]),
                         decision=decision))

    ctrl_net, rc = train("control", dict(net.arch), spec, seconds, net.state_dict())
    control = rc["val_psnr"]
    row("(none: control)", spec, rc, 0.0, "control")
    log(f"inputs: control (all of {ch.format_spec(spec)}): val {control:.2f} dB")
    ok, deltas, nets = [], {}, {}
    for g in groups:
        new_spec = tuple(x for x in spec if x != g)
        trial = drop_inputs(net, new_spec)
        nets[g], rt = train(f"drop-{g}", dict(trial.arch), new_spec, seconds, trial.state_dict())
        deltas[g] = control - rt["val_psnr"]
        good = deltas[g] <= drop_tol
        row(g, new_spec, rt, deltas[g], "can go" if good else "kept")
        log(f"inputs: without {g}: val {rt['val_psnr']:.2f} dB ({-deltas[g]:+.2f} dB vs control) -> "
            + ("can go" if good else "kept"))
        if good:
            ok.append(g)
    if not ok:
        return ctrl_net, spec, control
    new_spec = tuple(x for x in spec if x not in ok)
    if len(ok) > 1:  # together they may cost more than each alone
        trial = drop_inputs(net, new_spec)
        tnet, rt = train("drop-" + "+".join(ok), dict(trial.arch), new_spec, seconds, trial.state_dict())
        delta = control - rt["val_psnr"]
        good = delta <= drop_tol
        row(" + ".join(ok), new_spec, rt, delta, "dropped together" if good else "too much together")
        log(f"inputs: without {' + '.join(ok)}: val {rt['val_psnr']:.2f} dB ({-delta:+.2f} dB) -> "
            + ("dropped" if good else "too much together; dropping only the cheapest"))
        if good:
            _mark_dropped(rows, ok)
            return tnet, new_spec, control
        ok = [min(ok, key=lambda g: deltas[g])]
        new_spec = tuple(x for x in spec if x not in ok)
    _mark_dropped(rows, ok)
    return nets[ok[0]], new_spec, control


def _mark_dropped(rows, groups):
    for r in rows:
        if r.get("phase") == "inputs" and r.get("group") in groups:
            r["decision"] = "dropped"
