"""pcnet.models"""
