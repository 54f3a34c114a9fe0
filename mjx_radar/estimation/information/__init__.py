"""Fisher information of range measurements (SFIM, PFIM) and the PCRLB."""
