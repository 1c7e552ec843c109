"""Prediction at scale: many shapes, one trained model, on a Dask cluster."""
