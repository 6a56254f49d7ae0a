"""Reference data printed in the paper, for comparison and tests (not used by the allocators)."""

# Paper Table 2: the tasks each robot still does at the end of ExpT-MRTA.
PAPER_TABLE2 = {
    "R1": ("T1", "T3"),
    "R2": ("T1", "T5", "T7"),
    "R3": ("T4", "T6"),
    "R4": ("T8",),
    "R5": ("T2", "T8"),
    "R6": ("T1", "T2"),
    "R7": ("T3", "T6", "T7"),
    "R8": ("T5", "T8"),
    "R9": ("T2", "T7"),
    "R10": ("T3", "T4"),
}

# Learning-space figures the paper states (§7).
PAPER_SPACE_TABLE1 = 3498
PAPER_SPACE_TABLE2 = 550
PAPER_SPACE_R5 = (512, 162, 32)
