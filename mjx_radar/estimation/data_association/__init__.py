"""Data association of cluttered scans: PDA, JPDA (exact, JPDA*, LBP, multi-sensor), GNN and the
multiple-hypothesis tracker."""
