"""The fabric study (the fabric ZSL paper): embedding models on fabric groups, its tables, partitions and the
CNN+LSTM variant."""
