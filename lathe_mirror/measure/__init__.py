"""The made part comes back: measured profiles read (readers), fitted against the design
(fit), the machine's set-up errors diagnosed (diagnose), the measured part as a surface
(surface), and the re-cut's target (compensate)."""
