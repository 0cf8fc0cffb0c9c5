"""The closed-loop simulation engine: single runs and batches over scenarios, with streamed metrics."""
