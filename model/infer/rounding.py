"""How far two float32 evaluations of one network may differ: per-pixel rounding-error variances.

Two runtimes (torch and onnxruntime, or one of them on two CPUs) compute the same network on the same float32
inputs and weights, but sum the products of each convolution in different orders (SIMD width, blocking, FMA or
not, thread split) and evaluate exp and log with different kernels. Each result is the exact one plus rounding
errors that depend on the arithmetic, not on the CPU.

The worst case of those errors (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 3.1: a sum of n
terms in any order is within gamma_n sum |terms|, and a layer passes its input's error on through |W|) is useless
here: propagated through the shipped U-Net's twelve convolutions it grows by |W|'s gain each layer, to 3e4 in log
space, a bound that nothing fails. Rounding errors are not aligned with the signs of the weights, though. As in
probabilistic rounding-error analysis (Higham and Mary, SIAM J. Sci. Comput. 41(5), 2019), each rounding is
modelled as an independent error within +-u |result| (u = 2^-24, float32's unit roundoff; variance u^2 / 3 |result|^2)
and the variances are propagated to first order:

- a convolution of n = C_in k_h k_w products plus a bias: V(out) = W^2 * V(x) + n u^2 / 3 (|W| * |x| + |b|)^2, where
  ``*`` is the same convolution; the partial sums, which depend on the order, are bounded by the sum of |terms|;
- sums, products and quotients: first-order propagation of both operands' variances, plus one rounding;
- relu, clamp and nan_to_num are exact and 1-Lipschitz: V unchanged; leaky_relu adds one rounding;
- exp, expm1, log, log1p: the derivative squared times V, plus (``FN_ULPS`` u |out|)^2 (library functions are
  accurate to a few ulp; ONNX has no expm1 or log1p, and export.py writes them as Kahan's forms of about six
  rounded operations);
- views, slices, concatenation and padding move the variances with the values.

``variance(net, x)`` evaluates the network once in float64 (standing in for the exact values) under a dispatch
mode that carries a variance beside every intermediate tensor. export.py turns it into a per-pixel tolerance with
Hoeffding's inequality. An operation without a rule raises, so a network with a new kind of layer cannot pass a
parity check unbounded. The tolerance depends on the network and the pixel's values, not on the machine: it passes
wherever both results are correct float32 evaluations, and refuses one that computes something else (a changed
weight, a wrong operation).
"""
from __future__ import annotations

import copy

import numpy as np

U = 2.0 ** -24  # unit roundoff of float32
FN_ULPS = 8.0  # exp, log, expm1, log1p (and Kahan's forms of the latter two): within this many ulp


def variance(net, x: np.ndarray) -> np.ndarray:
    """The variance of float32 network(x) - exact network(x), elementwise, under the module doc's model, for ``net``
    (a torch module mapping 1xCxHxW to the output) and ``x`` (float32 1xCxHxW). Float64 array of the output's
    shape."""
    import torch

    mode_cls = _mode_class()
    net64 = copy.deepcopy(net).double().eval()
    xt = torch.from_numpy(np.asarray(x, np.float64))
    with torch.no_grad(), mode_cls() as mode:
        out = net64(xt)
        v = mode.var_of(out)
    return v.numpy()


_MODE = None


def _mode_class():
    """The dispatch mode class (built on first use: torch is imported only where a bound is asked for)."""
    global _MODE
    if _MODE is not None:
        return _MODE
    import torch
    from torch.utils._python_dispatch import TorchDispatchMode
    from torch.utils.weak import WeakTensorKeyDictionary

    aten = torch.ops.aten

    def absconv(x, w, b, args):  # the same convolution with other operands
        stride, padding, dilation, transposed, output_padding, groups = args
        return aten.convolution.default(x, w, b, stride, padding, dilation, transposed, output_padding, groups)

    class Mode(TorchDispatchMode):
        def __init__(self):
            super().__init__()
            self.var = WeakTensorKeyDictionary()

        def var_of(self, t):
            if not isinstance(t, torch.Tensor):
                return 0.0
            v = self.var.get(t)
            return torch.zeros_like(t) if v is None else v  # inputs and weights: exact, shared by both runtimes

        def __torch_dispatch__(self, func, types, args=(), kwargs=None):
            kwargs = kwargs or {}
            out = func(*args, **kwargs)
            if isinstance(out, torch.Tensor) and out.is_floating_point():
                self.var[out] = self._rule(func, args, kwargs, out)
            return out

        def _rule(self, func, args, kwargs, out):
            V = self.var_of
            p = func.overloadpacket
            a = args[0] if args else None
            r2 = U * U / 3.0 * out * out  # one rounding of the result: uniform in +-u |out|
            if p is aten.convolution:
                x, w, b = args[0], args[1], args[2]
                rest = tuple(args[3:])
                n = (w.shape[0] if rest[3] else w.shape[1]) * int(np.prod(w.shape[2:])) + (b is not None)
                mag = absconv(x.abs(), w.abs(), b.abs() if b is not None else None, rest)
                return absconv(V(x), w * w, None, rest) + (n / 3.0) * U * U * mag * mag
            if p in (aten.relu, aten.clamp, aten.clamp_min, aten.clamp_max, aten.nan_to_num, aten.hardtanh):
                return V(a).clone()
            if p is aten.leaky_relu:
                return V(a) + r2
            if p in (aten.add, aten.sub):
                alpha = kwargs.get("alpha", args[2] if len(args) > 2 else 1)
                return V(a) + alpha * alpha * _v(V, args[1]) + r2
            if p is aten.mul:
                b = args[1]
                return b * b * V(a) + a * a * _v(V, b) + r2
            if p is aten.div:
                b = args[1]
                return (V(a) + out * out * _v(V, b)) / (b * b) + r2
            fn2 = (FN_ULPS * U * out) ** 2  # a library function: its ulp bound, counted as a variance
            if p in (aten.exp, aten.expm1):
                return torch.exp(2.0 * a) * V(a) + fn2
            if p is aten.log1p:
                return V(a) / (1.0 + a) ** 2 + fn2
            if p is aten.log:
                return V(a) / (a * a) + fn2
            if p is aten.cat:
                return aten.cat.default([V(t) for t in args[0]], *args[1:], **kwargs)
            if p is aten.constant_pad_nd:
                return aten.constant_pad_nd.default(V(a), args[1], 0.0)
            if p in _MOVES:  # views, copies, slices, replicate padding: the variances move with the values
                return func(V(a), *args[1:], **kwargs)
            if p is aten.where:
                return aten.where.self(args[0], _v_full(V, args[1], out), _v_full(V, args[2], out))
            raise NotImplementedError(f"no rounding-error rule for {func}: add one to model/infer/rounding.py")

    _MOVES.update({aten.slice, aten.view, aten._unsafe_view, aten.reshape, aten.detach, aten.clone, aten.alias,
                   aten._to_copy, aten.contiguous, aten.select, aten.unsqueeze, aten.squeeze, aten.permute,
                   aten.expand, aten.t, aten.transpose, aten.replication_pad2d, aten.reflection_pad2d,
                   aten.lift_fresh, aten.narrow})
    _MODE = Mode
    return Mode


_MOVES: set = set()


def _v(V, v):
    return V(v) if hasattr(v, "shape") else 0.0


def _v_full(V, v, like):
    import torch
    return V(v) if isinstance(v, torch.Tensor) else torch.zeros_like(like)
