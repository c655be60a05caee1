//! The normal damping family (SPEC §2.2): one type per law in its own file
//! (`contact/damping/normal/<law>.rs`) implementing [`NormalDampingLaw`], and the registry that
//! makes [`NormalDamping`] and its dispatch. A new normal damping law is one file here and one
//! line in the registry, appended last (checkpoints encode the variant's index).

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
