"""Balance: desired ZMP from the support phases, Nishiwaki waist correction with variable CoM
height, fed back into the morph as a hard constraint on the waist marker (Nakaoka & Komura 2012,
sec. V). See docs/balance.md."""

from .loop import (
    BalanceConfig,
    BalanceIteration,
    BalanceResult,
    ConvergenceConfig,
    FlightPhaseError,
    ZmpState,
    balance_loop,
    check_flight,
    zmp_state,
)
from .nishiwaki import nishiwaki_correction

__all__ = ["BalanceConfig", "BalanceIteration", "BalanceResult", "ConvergenceConfig",
           "FlightPhaseError", "ZmpState", "balance_loop", "check_flight", "nishiwaki_correction",
           "zmp_state"]
