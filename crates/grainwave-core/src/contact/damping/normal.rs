//! The normal damping family (SPEC §2.2): one type per law in its own file
//! (`contact/damping/normal/<law>.rs`) implementing [`NormalDampingLaw`], and the registry that
//! makes [`NormalDamping`] and its dispatch; and the `[contact.damping]` tables
//! ([`DampingTable`]), one per way of choosing a normal damping law in a config (each law's
//! table in the law's file, `restitution` — the critical fraction that gives a restitution
//! coefficient — in a file of its own). A new normal damping law is one file here (the law, its
//! table and their tests) and one line in each registry, appended last (checkpoints encode the
//! law's variant index).

use super::NormalDampingLaw;

damping_laws! {
    /// Normal viscous damping: a force γ_n |v_n| opposing the relative normal velocity, none or
    /// one of the registered laws ([`NormalDampingLaw`]); encoded as the variant's name and the
    /// law's fields (`"none"` for none).
    NormalDamping: NormalDampingLaw {
        dashpot::Dashpot,
        critical_fraction::CriticalFraction,
        mass_proportional::MassProportional,
        tsuji::Tsuji,
    }
}

mod restitution;

damping_tables! {
    Restitution(restitution::RestitutionTable),
    Dashpot(dashpot::DashpotTable),
    CriticalFraction(critical_fraction::CriticalFractionTable),
    MassProportional(mass_proportional::MassProportionalTable),
    Tsuji(tsuji::TsujiTable),
}
