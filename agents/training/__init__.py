"""Training runs: settings and run folders, policies, warm starts, ONNX export, machine
records and stop signals."""
