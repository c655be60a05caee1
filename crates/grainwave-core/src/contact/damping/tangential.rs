//! The tangential damping family: one type per law in its own file
//! (`contact/damping/tangential/<law>.rs`) implementing [`TangentialDampingLaw`], and the
//! registry that makes [`TangentialDamping`] and its dispatch. A new tangential damping law is
//! one file here and one line in the registry, appended last (checkpoints encode the variant's
//! index).

use super::TangentialDampingLaw;

damping_laws! {
    /// Tangential viscous damping γ_t, none or one of the registered laws
    /// ([`TangentialDampingLaw`]); encoded as the variant's name and the law's fields (`"none"`
    /// for none).
    TangentialDamping: TangentialDampingLaw {
        coefficient::Coefficient,
        fraction_of_normal::FractionOfNormal,
        critical_fraction::CriticalFraction,
        mass_proportional::MassProportional,
    }
}
