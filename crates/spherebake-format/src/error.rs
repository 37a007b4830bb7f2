//! Validation errors with stable rule IDs (KTX-Software style).

use core::fmt;

/// A known section kind of `.sphb` v1 (the `kind` field of a section table entry).
///
/// Unknown kinds are skipped by the reader; they never appear in this enum.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SectionKind {
    /// Sphere set: centre and radius per sphere, model space (required).
    Spheres,
    /// Sphere hierarchy: nodes, child nodes, leaf spheres, root.
    Hierarchy,
    /// Surface sample points per sphere.
    Samples,
    /// Albedo spherical harmonics per sphere.
    AlbedoSh,
    /// Per-sphere skinning terms.
    Skin,
    /// Bone table.
    Bones,
    /// Metadata key/value strings.
    Metadata,
    /// Surface sample points per sphere, quantised (format minor 1): 16-bit positions in a
    /// per-sphere box, octahedral 2 × 16-bit normals.
    CompactSamples,
    /// Albedo spherical harmonics per sphere as binary16 floats (format minor 1).
    CompactAlbedoSh,
    /// The surface area each sample stands for (format minor 2).
    SampleAreas,
}

impl SectionKind {
    /// Every known kind, in file order (ascending kind code).
    pub const ALL: [SectionKind; 10] = [
        SectionKind::Spheres,
        SectionKind::Hierarchy,
        SectionKind::Samples,
        SectionKind::AlbedoSh,
        SectionKind::Skin,
        SectionKind::Bones,
        SectionKind::Metadata,
        SectionKind::CompactSamples,
        SectionKind::CompactAlbedoSh,
        SectionKind::SampleAreas,
    ];

    /// The `kind` code stored in the section table.
    #[must_use]
    pub const fn code(self) -> u32 {
        match self {
            SectionKind::Spheres => 1,
            SectionKind::Hierarchy => 2,
            SectionKind::Samples => 3,
            SectionKind::AlbedoSh => 4,
            SectionKind::Skin => 5,
            SectionKind::Bones => 6,
            SectionKind::Metadata => 7,
            SectionKind::CompactSamples => 8,
            SectionKind::CompactAlbedoSh => 9,
            SectionKind::SampleAreas => 10,
        }
    }

    /// The known kind with this code, `None` for an unknown (skipped) kind.
    #[must_use]
    pub const fn from_code(code: u32) -> Option<SectionKind> {
        match code {
            1 => Some(SectionKind::Spheres),
            2 => Some(SectionKind::Hierarchy),
            3 => Some(SectionKind::Samples),
            4 => Some(SectionKind::AlbedoSh),
            5 => Some(SectionKind::Skin),
            6 => Some(SectionKind::Bones),
            7 => Some(SectionKind::Metadata),
            8 => Some(SectionKind::CompactSamples),
            9 => Some(SectionKind::CompactAlbedoSh),
            10 => Some(SectionKind::SampleAreas),
            _ => None,
        }
    }

    /// Lower-case name used in messages and in the specification.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            SectionKind::Spheres => "spheres",
            SectionKind::Hierarchy => "hierarchy",
            SectionKind::Samples => "samples",
            SectionKind::AlbedoSh => "albedo_sh",
            SectionKind::Skin => "skin",
            SectionKind::Bones => "bones",
            SectionKind::Metadata => "metadata",
            SectionKind::CompactSamples => "samples_q16",
            SectionKind::CompactAlbedoSh => "albedo_sh_f16",
            SectionKind::SampleAreas => "sample_areas",
        }
    }

    /// The lossless kind whose data this kind carries in compact form (itself when lossless):
    /// samples for `samples_q16`, albedo SH for `albedo_sh_f16`. A file holds at most one
    /// section of each lossless kind's family (rule 2011).
    #[must_use]
    pub const fn family(self) -> SectionKind {
        match self {
            SectionKind::CompactSamples => SectionKind::Samples,
            SectionKind::CompactAlbedoSh => SectionKind::AlbedoSh,
            k => k,
        }
    }
}

macro_rules! rules {
    ($( $(#[$doc:meta])* $name:ident = $id:literal, $msg:literal; )*) => {
        /// One validation rule of the specification (`formats/spherebake-v1.md`).
        ///
        /// The numeric ID ([`Rule::id`]) is stable: it never changes meaning once published.
        /// IDs are grouped by section: 1xxx header, 2xxx section table, 3xxx spheres,
        /// 4xxx hierarchy, 5xxx samples, 6xxx albedo SH, 7xxx skin, 8xxx bones, 9xxx metadata.
        #[non_exhaustive]
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u16)]
        pub enum Rule {
            $( $(#[$doc])* $name = $id, )*
        }

        impl Rule {
            /// Every rule, in ascending ID order.
            pub const ALL: &'static [Rule] = &[ $( Rule::$name, )* ];

            /// The stable numeric rule ID.
            #[must_use]
            pub const fn id(self) -> u16 {
                self as u16
            }

            /// One-line description of what the rule requires (same text as the specification).
            #[must_use]
            pub const fn message(self) -> &'static str {
                match self {
                    $( Rule::$name => $msg, )*
                }
            }
        }
    };
}

rules! {
    /// The file is shorter than the fixed header.
    FileTooSmall = 1001, "file is at least 64 bytes long";
    /// The magic bytes are wrong.
    BadMagic = 1002, "bytes 0..8 are the magic 89 53 50 48 42 0D 0A 1A";
    /// The major version is not one this reader knows.
    UnsupportedMajor = 1003, "major version is 1";
    /// The header size field is invalid.
    HeaderSize = 1004, "header size is 64 for minors 0 to 2, a multiple of 16 and at least 64 for newer minors, and fits in the file";
    /// The header checksum does not match.
    HeaderChecksum = 1005, "header CRC-32 matches bytes 0..44";
    /// The file size field does not equal the number of bytes.
    FileSize = 1006, "file size field equals the byte count of the file";
    /// The file size is not a multiple of 16.
    FileAlignment = 1007, "file size is a multiple of 16";
    /// The section table offset is misaligned or overlaps the header.
    TableOffset = 2001, "section table offset is a multiple of 16 and not below the header size";
    /// The section table does not fit in the file.
    TableBounds = 2002, "section table (count x 32 bytes) lies inside the file";
    /// The section table checksum does not match.
    TableChecksum = 2003, "section table CRC-32 matches the table bytes";
    /// A section offset is not 16-byte aligned.
    SectionAlignment = 2004, "section offset is a multiple of 16";
    /// A section does not fit in the file or overlaps the header or table.
    SectionBounds = 2005, "section lies inside the file, after the section table";
    /// Sections overlap or are not in ascending offset order.
    SectionOrder = 2006, "sections are in ascending offset order and do not overlap";
    /// A known section kind appears twice.
    DuplicateSection = 2007, "each known section kind appears at most once";
    /// A section checksum does not match.
    SectionChecksum = 2008, "section CRC-32 matches the section bytes";
    /// The required sphere section is absent.
    MissingSpheres = 2009, "the spheres section is present";
    /// A byte outside header, table and sections is not zero.
    NonZeroPadding = 2010, "every byte outside the header, the table and the sections is zero";
    /// Both the lossless and the compact section of the same data are present.
    SectionConflict = 2011, "a file holds at most one of samples and samples_q16 and at most one of albedo_sh and albedo_sh_f16";
    /// The sphere section length does not match its count.
    SpheresLength = 3001, "spheres section length is 16 + 16 x sphere count";
    /// The sphere count is zero.
    SpheresEmpty = 3002, "sphere count is at least 1";
    /// A sphere centre is not finite.
    SphereCentre = 3003, "sphere centre coordinates are finite";
    /// A sphere radius is not finite and positive.
    SphereRadius = 3004, "sphere radius is finite and greater than 0";
    /// The hierarchy section length does not match its counts.
    HierarchyLength = 4001, "hierarchy section length is 16 + 32 x node count + 4 x (child count + leaf count)";
    /// The hierarchy has no node.
    HierarchyEmpty = 4002, "hierarchy node count is at least 1";
    /// The root index is out of range.
    HierarchyRoot = 4003, "root index is below the node count";
    /// A node centre is not finite.
    NodeCentre = 4004, "node centre coordinates are finite";
    /// A node radius is not finite and positive.
    NodeRadius = 4005, "node radius is finite and greater than 0";
    /// A node's child range exceeds the child array.
    NodeChildRange = 4006, "node child range lies inside the child array";
    /// A node's leaf range exceeds the leaf array.
    NodeLeafRange = 4007, "node leaf range lies inside the leaf array";
    /// A child index is out of range.
    ChildIndex = 4008, "child node index is below the node count";
    /// A leaf index is out of range.
    LeafIndex = 4009, "leaf sphere index is below the sphere count";
    /// A node is reached twice from the root (cycle or shared subtree).
    NodeRevisited = 4010, "every node is reached at most once from the root (acyclic tree)";
    /// A node is not reachable from the root.
    NodeUnreachable = 4011, "every node is reachable from the root";
    /// A sphere is reached twice as a leaf.
    LeafRevisited = 4012, "every sphere is a leaf of at most one node";
    /// A sphere is not reachable as a leaf.
    LeafUnreachable = 4013, "every sphere is reachable as a leaf from the root";
    /// A node has neither children nor leaves.
    NodeEmpty = 4014, "every node has at least one child or leaf";
    /// The samples section length does not match its counts.
    SamplesLength = 5001, "samples section length is 16 + pad16(4 x (sphere count + 1)) + 32 x sample count";
    /// The samples section's sphere count differs from the sphere set.
    SamplesSphereCount = 5002, "samples sphere count equals the sphere count";
    /// The per-sphere offset table is inconsistent.
    SampleOffsets = 5003, "sample offsets start at 0, never decrease and end at the sample count";
    /// A sample position is not finite.
    SamplePosition = 5004, "sample position coordinates are finite";
    /// A sample normal is not a finite unit vector.
    SampleNormal = 5005, "sample normal is finite with length within 1e-3 of 1";
    /// A sample direction index is out of range.
    SampleDirection = 5006, "sample direction index is below 92";
    /// A sample rule is not 1, 2 or 3.
    SampleRule = 5007, "sample rule is 1, 2 or 3";
    /// Sample directions of one sphere are not strictly increasing.
    SampleDirectionOrder = 5008, "direction indices of one sphere's samples strictly increase";
    /// The compact samples section length does not match its counts.
    CompactSamplesLength = 5009, "samples_q16 section length is 16 + pad16(4 x (sphere count + 1)) + 24 x sphere count + 12 x sample count";
    /// A sample quantisation box is invalid.
    SampleBox = 5010, "sample box origin and step are finite, step >= 0, and origin + 65535 x step is finite";
    /// An octahedral normal component is -32768.
    SampleOctNormal = 5011, "octahedral normal components are in -32767..=32767";
    /// The sample areas section length does not match its count.
    SampleAreasLength = 5012, "sample_areas section length is 16 + 4 x sample count (encoding 0) or 16 + 2 x sample count (encoding 1)";
    /// The sample areas do not match the samples.
    SampleAreasCount = 5013, "sample_areas needs a samples section (kind 3 or 8) and its sample count equals that section's";
    /// A sample area is negative or not finite.
    SampleArea = 5014, "sample areas are finite and >= 0";
    /// The sample areas' encoding is unknown.
    SampleAreasEncoding = 5015, "sample_areas encoding is 0 (f32, model units squared) or 1 (f16, units of the sphere's radius squared)";
    /// The SH section length does not match its counts.
    ShLength = 6001, "albedo SH section length is 16 + 12 x sphere count x order squared";
    /// The SH section's sphere count differs from the sphere set.
    ShSphereCount = 6002, "albedo SH sphere count equals the sphere count";
    /// The SH order is out of range.
    ShOrder = 6003, "SH order is in 1..=8";
    /// The colour space code is unknown.
    ShColourSpace = 6004, "colour space is 0 (linear RGB)";
    /// The SH basis code is unknown.
    ShBasis = 6005, "SH basis is 0 (real orthonormal, Condon-Shortley phase, i = l(l+1)+m)";
    /// An SH coefficient is not finite.
    ShCoefficient = 6006, "SH coefficients are finite";
    /// The compact SH section length does not match its counts.
    CompactShLength = 6007, "albedo_sh_f16 section length is 16 + 6 x sphere count x order squared";
    /// The skin section length does not match its counts.
    SkinLength = 7001, "skin section length is 16 + 20 x sphere count x bones per sphere";
    /// The skin section's sphere count differs from the sphere set.
    SkinSphereCount = 7002, "skin sphere count equals the sphere count";
    /// Bones per sphere is out of range.
    SkinBonesPerSphere = 7003, "bones per sphere is in 1..=64";
    /// A skin section is present without a bone table.
    SkinWithoutBones = 7004, "a file with a skin section has a bones section";
    /// A skin bone index is out of range.
    SkinBoneIndex = 7005, "skin bone index is below the bone count or 0xFFFFFFFF (unused)";
    /// A skin term is not finite.
    SkinTerm = 7006, "skin terms q and b are finite";
    /// An unused skin slot has non-zero terms.
    SkinUnusedSlot = 7007, "an unused skin slot has q = (0, 0, 0) and b = 0";
    /// The bones section length does not match its counts.
    BonesLength = 8001, "bones section length is 16 + 80 x bone count + name byte count";
    /// A bone name range exceeds the name bytes.
    BoneNameRange = 8002, "bone name range lies inside the name bytes";
    /// A bone name is not UTF-8.
    BoneNameUtf8 = 8003, "bone name is valid UTF-8";
    /// A bone parent index is out of range.
    BoneParent = 8004, "bone parent is below the bone count or 0xFFFFFFFF (none)";
    /// The bone parent links form a cycle.
    BoneCycle = 8005, "bone parent links are acyclic";
    /// An inverse bind matrix entry is not finite.
    BoneMatrix = 8006, "inverse bind matrix entries are finite";
    /// The metadata section length does not match its counts.
    MetadataLength = 9001, "metadata section length is 16 + 16 x entry count + string byte count";
    /// A metadata string range exceeds the string bytes.
    MetadataStringRange = 9002, "metadata key and value ranges lie inside the string bytes";
    /// A metadata string is not UTF-8.
    MetadataUtf8 = 9003, "metadata keys and values are valid UTF-8";
    /// A metadata key is empty.
    MetadataEmptyKey = 9004, "metadata keys are not empty";
    /// A metadata key appears twice.
    MetadataDuplicateKey = 9005, "metadata keys are unique";
    /// A required metadata key is missing.
    MetadataMissingKey = 9006, "metadata has the keys tool_version, settings, input_hash and units";
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rule {}: {}", self.id(), self.message())
    }
}

/// An expected or actual value attached to a [`ValidationError`].
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Detail {
    /// No value applies.
    None,
    /// An integer (count, index, offset, size, code, checksum).
    Int(u64),
    /// A floating-point value as stored.
    Float(f32),
    /// A description (e.g. "finite", "< 92").
    Text(&'static str),
}

impl fmt::Display for Detail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Detail::None => f.write_str("-"),
            Detail::Int(v) => write!(f, "{v}"),
            Detail::Float(v) => write!(f, "{v:?}"),
            Detail::Text(t) => f.write_str(t),
        }
    }
}

/// Why a byte string is not a valid `.sphb` file.
///
/// Reports the violated [`Rule`], the section it was found in (`None` for the header and
/// section table), the absolute byte offset of the offending field, and the expected and
/// actual values where they apply.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValidationError {
    /// The violated rule; `rule.id()` is the stable numeric ID.
    pub rule: Rule,
    /// The section being read, `None` for header and section table checks.
    pub section: Option<SectionKind>,
    /// Absolute byte offset (from the start of the file) of the offending field.
    pub offset: u64,
    /// What the rule requires.
    pub expected: Detail,
    /// What the file holds.
    pub actual: Detail,
}

impl ValidationError {
    /// A new error; used by the reader, public so that tools can report their own checks alike.
    #[must_use]
    pub const fn new(rule: Rule, section: Option<SectionKind>, offset: u64, expected: Detail, actual: Detail) -> Self {
        ValidationError { rule, section, offset, expected, actual }
    }
}

impl fmt::Display for ValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rule {} ", self.rule.id())?;
        match self.section {
            Some(kind) => write!(f, "(section {})", kind.name())?,
            None => f.write_str("(header)")?,
        }
        write!(
            f,
            " at byte {}: {}; expected {}, found {}",
            self.offset,
            self.rule.message(),
            self.expected,
            self.actual
        )
    }
}

impl core::error::Error for ValidationError {}
