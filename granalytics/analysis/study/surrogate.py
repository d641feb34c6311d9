"""A Gaussian-process surrogate of a study: regression of the steady-state metrics on the swept
inputs, with leave-one-out errors (:func:`fit_surrogate`, :class:`Surrogate`).
"""

from __future__ import annotations

import math
import warnings
from numbers import Integral

import numpy as np
import pandas as pd

from granalytics.analysis.metrics import HEADLINE
from granalytics.analysis.study.sweep_table import select_cohesion
from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.base.validation import Array, Instance, Interval, validate_params
from granalytics.identification.cohesion import COHESION




# ----------------------------------------------------------------------------- the surrogate
class Surrogate:
    """Gaussian-process surrogate of steady-state metrics (:func:`fit_surrogate`).

    Attributes
    ----------
    inputs, outputs : list of str
    models : dict
        Output -> fitted ``GaussianProcessRegressor`` (on standardised inputs; ``normalize_y``).
    data : DataFrame
        The training rows (inputs and outputs).
    """

    def __init__(self, inputs, outputs, models, scaler, data, n_restarts):
        self.inputs = list(inputs)
        self.outputs = list(outputs)
        self.models = models
        self._mean, self._scale = scaler
        self.data = data
        self._n_restarts = n_restarts
        self._loo = None
        self._loo_predictions = None

    def _x(self, frame):
        return (frame[self.inputs].to_numpy(dtype=float) - self._mean) / self._scale

    @validate_params({"points": [Instance((dict, pd.DataFrame))]})
    def predict(self, points) -> pd.DataFrame:
        """Predicted mean and standard deviation of every output.

        Parameters
        ----------
        points : dict or DataFrame
            Values of exactly the surrogate's inputs (scalars or equal-length lists), e.g.
            ``{"gamma": 0.2, "omega": 3.0}``.

        Returns
        -------
        DataFrame
            The inputs, then ``<output>`` (mean) and ``<output>_std`` (predictive standard
            deviation, including the fitted white-noise level: the scatter expected of a new run).
        """
        unknown = sorted(set(points) - set(self.inputs)) if isinstance(points, dict) else []
        if unknown:
            raise ParameterError(f"unknown input {unknown[0]!r}; the surrogate's inputs are {self.inputs}")
        missing = [k for k in self.inputs if k not in points]
        if missing:
            raise ParameterError(f"missing input {missing[0]!r}; the surrogate's inputs are {self.inputs}")
        try:
            frame = pd.DataFrame({k: np.atleast_1d(points[k]) for k in self.inputs}) if isinstance(points, dict) \
                else points
            values = frame[self.inputs].to_numpy(dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"prediction inputs must be numbers ({exc})") from None
        if not np.isfinite(values).all():
            raise ParameterError("prediction inputs must be finite numbers")
        trained = self.data[self.inputs].to_numpy(dtype=float)
        low, high = trained.min(axis=0), trained.max(axis=0)
        outside = [f"{name} = {v:g} (trained on [{lo:g}, {hi:g}])" for row in values
                   for name, v, lo, hi in zip(self.inputs, row, low, high) if not lo <= v <= hi]
        if outside:
            warnings.warn("surrogate: extrapolating outside the sweep, where a Gaussian process returns to its "
                          "mean: " + "; ".join(outside), stacklevel=user_stacklevel())
        out = pd.DataFrame(values, columns=self.inputs)
        x = (values - self._mean) / self._scale
        for name in self.outputs:
            mean, std = self.models[name].predict(x, return_std=True)
            out[name] = mean
            out[f"{name}_std"] = std
        return out

    def _compute_loo(self):
        from sklearn.base import clone

        errors, preds = {}, []
        for name in self.outputs:
            rows = self.data[np.isfinite(self.data[name].to_numpy(dtype=float))]
            x, y = self._x(rows), rows[name].to_numpy(dtype=float)
            fitted = self.models[name]
            predicted = np.empty_like(y)
            for i in range(len(y)):
                keep = np.arange(len(y)) != i
                model = clone(fitted)
                model.set_params(kernel=fitted.kernel_, n_restarts_optimizer=0)  # start from the full fit
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model.fit(x[keep], y[keep])
                predicted[i] = model.predict(x[i:i + 1])[0]
            err = predicted - y
            errors[name] = {"rmse": float(np.sqrt(np.mean(err**2))), "mae": float(np.mean(np.abs(err))),
                            "output_std": float(np.std(y, ddof=1)) if len(y) > 1 else math.nan,
                            "n_points": int(len(y))}
            part = rows[self.inputs].copy()
            part["output"] = name
            part["observed"] = y
            part["predicted"] = predicted
            preds.append(part)
        table = pd.DataFrame(errors).T
        table.index.name = "output"
        self._loo = table.astype({"n_points": int})
        self._loo_predictions = pd.concat(preds, ignore_index=True)

    @property
    def loo(self) -> pd.DataFrame:
        """Leave-one-out error per output (index): ``rmse``, ``mae`` (of the prediction of each
        point by a GP refitted without it, hyperparameters re-optimised from the full fit's),
        ``output_std`` (scale of the output, for comparison) and ``n_points``. Computed on first
        access."""
        if self._loo is None:
            self._compute_loo()
        return self._loo

    @property
    def loo_predictions(self) -> pd.DataFrame:
        """The leave-one-out predictions behind :attr:`loo`: inputs, ``output``, ``observed``,
        ``predicted``."""
        if self._loo_predictions is None:
            self._compute_loo()
        return self._loo_predictions


@validate_params({"table": [Instance(pd.DataFrame, "a study table (a DataFrame, study_table's result)")],
                  "inputs": [Array(ndim=1, dtype=str)], "outputs": [Array(ndim=1, dtype=str), None],
                  "cohesion": [COHESION, None], "n_restarts": [Interval(Integral, 0, None)]})
def fit_surrogate(table, inputs=("gamma", "omega"), outputs=None, *, cohesion="acting",
                  n_restarts=3, random_state=0) -> Surrogate:
    """Gaussian-process regression of each output on the inputs.

    One ``sklearn.gaussian_process.GaussianProcessRegressor`` per output, on inputs standardised
    to zero mean and unit variance, ``normalize_y=True``, kernel
    ``ConstantKernel · RBF(one length scale per input) + WhiteKernel`` (the white term absorbs
    the run-to-run scatter, e.g. between seeds). Rows with a NaN output (e.g. the mean granule
    volume of a point without granules) are left out of that output's model.

    Parameters
    ----------
    table : DataFrame
        :func:`study_table` output (or any table with the input and output columns).
    inputs, outputs : sequence of str
        Columns of the table; ``outputs`` default ``<metric>_mean`` of every headline metric
        (:data:`granalytics.analysis.metrics.HEADLINE`).
    cohesion : str, default "acting"
        When the table has several cohesion conventions, fit this one's rows.
    n_restarts : int, default 3
        Restarts of the kernel hyperparameter optimiser.
    random_state : int, default 0

    Returns
    -------
    Surrogate
    """
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    inputs = list(inputs)
    outputs = [f"{name}_mean" for name in HEADLINE] if outputs is None else list(outputs)
    if not inputs or not outputs:
        raise ParameterError("give at least one input and one output")
    part = select_cohesion(table, cohesion)
    missing = [c for c in inputs + outputs if c not in part]
    if missing:
        raise ParameterError(f"the table has no column {missing[0]!r}; columns: {list(part.columns)}")
    data = part[inputs + outputs].reset_index(drop=True)
    try:
        x_all = data[inputs].to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"inputs {inputs} must be numeric columns") from None
    if not np.isfinite(x_all).all():
        raise ParameterError("the inputs have missing or non-finite values")
    mean = x_all.mean(axis=0)
    scale = x_all.std(axis=0)
    scale[scale == 0] = 1.0
    models = {}
    for name in outputs:
        y = data[name].to_numpy(dtype=float)
        ok = np.isfinite(y)
        if ok.sum() < 3:
            raise ParameterError(f"output {name!r}: the surrogate needs at least three points, got {int(ok.sum())}")
        kernel = (ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(len(inputs)), (1e-2, 1e2))
                  + WhiteKernel(1e-2, (1e-8, 1e1)))
        gp = GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=n_restarts,
                                      random_state=random_state)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # convergence warnings at the bounds
            gp.fit((x_all[ok] - mean) / scale, y[ok])
        models[name] = gp
    return Surrogate(inputs, outputs, models, (mean, scale), data, n_restarts)

