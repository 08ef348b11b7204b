"""Active touch: choosing the next exploratory procedure, the stopping rule, and its hand variant."""
