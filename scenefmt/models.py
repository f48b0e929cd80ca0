"""Every scene-format model in one namespace, for users building scenes in Python."""

from .base import Color, Name, Number, Vec3
from .lights import DirectionalLight, Light, PointLight, SpotLight
from .materials import Dielectric, DiffuseLight, Isotropic, Lambertian, Material, MaterialSlot, Metal
from .media import ConstantMedium, Medium, MediumSlot
from .scene import (
    FORMAT_VERSION,
    Background,
    Camera,
    Image,
    ImageBackground,
    Scene,
    Shutter,
    SkyBackground,
    SolidBackground,
)
from .sky import SunSkyBackground
from .shapes import Box, Disk, Group, GroupSlot, Instance, Mesh, MovingSphere, Quad, Shape, Sphere, Triangle
from .textures import CheckerTexture, ImageTexture, NoiseTexture, SolidTexture, Texture, TextureSlot
from .transforms import MatrixStep, RotateStep, Rotation, ScaleStep, TransformStep, TranslateStep

__all__ = [
    "FORMAT_VERSION", "Background", "Box", "Camera", "CheckerTexture", "Color", "ConstantMedium", "Dielectric",
    "DiffuseLight", "Disk", "Group", "GroupSlot", "Image", "ImageBackground", "ImageTexture", "Instance", "Isotropic", "Lambertian",
    "Material", "MaterialSlot", "MatrixStep", "Mesh", "Medium", "MediumSlot", "Metal", "MovingSphere", "Name", "NoiseTexture",
    "Number", "Quad", "RotateStep", "Rotation", "ScaleStep", "Scene", "Shape", "Shutter", "SkyBackground",
    "SolidBackground", "SolidTexture", "Sphere", "SunSkyBackground", "Texture", "TextureSlot", "TransformStep", "TranslateStep",
    "Triangle", "Vec3", "Light", "PointLight", "SpotLight", "DirectionalLight",
]
