"""Scaramuzza's OCamCalib model of a lobe (calib_results.txt): the polynomials fitted to the
design's unified model, in plain powers converted exactly from a rounded Chebyshev fit, so
the written coefficients do not drift with the BLAS or the CPU (export.numbers)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..design import Mirror
from .camera_model import UnifiedModel, design_model

#: The OCamCalib polynomials are raised in degree until they hold the exact map to this, px.
OCAM_TOLERANCE_PX = 1e-4


@dataclass(frozen=True)
class OcamModel:
    """Scaramuzza's OCamCalib model of one lobe (calib_results.txt).

    pol: ascending coefficients of f(rho) (rho in px): the ray of an image point at
    (x, y) px from the centre (x along the rows, y along the columns) is (x, y, f(rho)).
    invpol: ascending coefficients of rho(theta), theta = atan(z / sqrt(x^2 + y^2)) (rad).
    xc, yc: the centre's row and column from 0, px. width, height: px. max_error_px: the
    largest departure from the exact map of each polynomial over its fitted range, px.
    Its frame: origin F1, x along the rows (camera y), y along the columns (camera x), z up
    the axis away from the camera; the lobe frame with x, y swapped and z reversed.
    """

    name: str
    pol: np.ndarray
    invpol: np.ndarray
    xc: float
    yc: float
    width: int
    height: int
    rho_max_px: float
    max_error_px: dict


def ocam_model(model: UnifiedModel, rho_max_px: float, *, tolerance_px: float = OCAM_TOLERANCE_PX,
               max_degree: int = 24) -> OcamModel:
    """Scaramuzza's polynomials fitted to an undistorted unified model (a lobe's exact map).

    Direct: f(rho) = gamma (xi / lambda - 1) with lambda = (xi + sqrt(1 + (1 - xi^2) m^2)) /
    (1 + m^2), m = rho / gamma (Mei's lifting, seen in OCamCalib's frame), an even function:
    fitted in even powers of rho on [0, rho_max_px]. Inverse: rho(theta) = gamma cos(theta) /
    (xi - sin(theta)) on theta from -pi/2 to the elevation at rho_max_px. Each is a
    least-squares Chebyshev fit (well conditioned), converted to plain powers, of the lowest
    degree whose pixel error stays within tolerance_px.
    """
    from numpy.polynomial import Chebyshev, Polynomial

    if model.k1 or model.k2 or model.fu != model.fv:
        raise ValueError("ocam_model: needs an undistorted model with fu == fv")
    g, xi, big_r = model.fu, model.xi, float(rho_max_px)
    rho = np.linspace(0.0, big_r, 4001)
    f_exact = _ocam_f(rho, g, xi)

    pol = pol_err = None
    for deg in range(1, max_degree // 2 + 1):
        c = Chebyshev.fit((rho / big_r) ** 2, f_exact, deg, domain=[0.0, 1.0])
        # f in powers of s = (rho / R)^2, then of rho: a_2k = c_k / R^2k, exactly.
        coef_s = _power_coefficients(c.coef, Fraction(0), Fraction(1))
        coef = np.zeros(2 * len(coef_s) - 1)
        coef[::2] = [float(ck / Fraction(big_r) ** (2 * k)) for k, ck in enumerate(coef_s)]
        phi = np.arctan2(np.polynomial.polynomial.polyval(rho, coef), rho)
        pol_err = float(np.max(np.abs(model.radius_px(phi) - rho)))
        pol = coef
        if pol_err <= tolerance_px:
            break

    # theta's upper end at 1e-12 rad, so the exact conversion below starts from fixed numbers.
    theta_hi = round(math.atan2(float(f_exact[-1]), big_r), 12)
    theta = np.linspace(-math.pi / 2, theta_hi, 4001)
    rho_t = model.radius_px(theta)
    invpol = inv_err = None
    lo = Fraction(-math.pi / 2)
    for deg in range(1, max_degree + 1):
        c = Chebyshev.fit(theta, rho_t, deg, domain=[-math.pi / 2, theta_hi])
        coef = np.array([float(x) for x in _power_coefficients(c.coef, lo, Fraction(theta_hi))])
        inv_err = float(np.max(np.abs(np.polynomial.polynomial.polyval(theta, coef) - rho_t)))
        invpol = coef
        if inv_err <= tolerance_px:
            break
    w, h = model.image_size
    return OcamModel(name=model.name, pol=pol, invpol=invpol, xc=model.cy, yc=model.cx,
                     width=w, height=h, rho_max_px=big_r,
                     max_error_px={"pol": pol_err, "invpol": inv_err})


def lobe_ocam_model(mirror: Mirror, k: int, zones=None) -> OcamModel:
    """ocam_model of lobe k's design model over its whole image disc (to the rim, R_pixel)."""
    return ocam_model(design_model(mirror, k, zones), mirror.lobes[k].r_pixel)


#: A Chebyshev coefficient of an OCamCalib fit is rounded to this (px: each T_k is at most 1
#: on the fit's interval) before its exact conversion to plain powers. The fit itself is
#: well conditioned (its coefficients move by ~1e-13 px with the last bit of the map), the
#: conversion to powers is not (1e5 to 1e8): rounded first and converted in rationals, the
#: written polynomials cannot drift with the BLAS or the CPU (export.numbers).
CHEBYSHEV_STEP_PX = 1e-10


def _power_coefficients(cheb: np.ndarray, lo: Fraction, hi: Fraction) -> list[Fraction]:
    """Exact ascending power coefficients in x of sum_k c_k T_k(t), t = (2x - lo - hi) /
    (hi - lo) (numpy's Chebyshev with domain [lo, hi]), each c_k first rounded to
    CHEBYSHEV_STEP_PX."""
    steps = round(1 / CHEBYSHEV_STEP_PX)
    c = [Fraction(round(float(ck) * steps), steps) for ck in cheb]
    n = len(c)
    # The series in powers of t: T_0 = 1, T_1 = t, T_k+1 = 2 t T_k - T_k-1.
    series = [Fraction(0)] * n
    t_prev, t_cur = [Fraction(1)], [Fraction(0), Fraction(1)]
    series[0] += c[0]
    for k in range(1, n):
        for i, x in enumerate(t_cur):
            series[i] += c[k] * x
        nxt = [Fraction(0)] + [2 * x for x in t_cur]
        for i, x in enumerate(t_prev):
            nxt[i] -= x
        t_prev, t_cur = t_cur, nxt
    # t = a x + b: expand sum_j s_j (a x + b)^j.
    a, b = 2 / (hi - lo), -(hi + lo) / (hi - lo)
    out = [Fraction(0)] * n
    power = [Fraction(1)]
    for j in range(n):
        for i, x in enumerate(power):
            out[i] += series[j] * x
        new = [Fraction(0)] * (len(power) + 1)
        for i, x in enumerate(power):
            new[i] += b * x
            new[i + 1] += a * x
        power = new
    return out


def _ocam_f(rho: np.ndarray, gamma: float, xi: float) -> np.ndarray:
    """OCamCalib's f(rho) of the unified model: z of the ray (x, y, f) with |(x, y)| = rho
    in its frame (z up the axis), from Mei's lifting."""
    r2 = (rho / gamma) ** 2
    lam = (xi + np.sqrt(1.0 + (1.0 - xi * xi) * r2)) / (1.0 + r2)
    return gamma * (xi / lam - 1.0)
