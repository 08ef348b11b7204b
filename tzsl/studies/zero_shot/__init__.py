"""The zero-shot study (any dataset x DAP and every registered method x random/challenging splits, GZSL)
and its PHAC-2 paper preset's tables."""
