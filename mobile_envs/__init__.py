"""Gymnasium environments in which a wheeled robot follows a path."""
