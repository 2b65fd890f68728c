"""How answers are written: JSON (answers.py), the binary form (binary.py), and the answer
budget checked before computing (budget.py)."""
